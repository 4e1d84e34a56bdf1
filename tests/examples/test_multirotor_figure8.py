"""The multirotor example of diagrams/ (issue #32), briefly: a quadrotor and a hexarotor from
SDF text + Drake Propellers, W2/W∞ + allocation beside Drake's LQR, recorded to HTML."""

import importlib.util
import math
from pathlib import Path

import sobolev_drake as sd

SCRIPT = Path(__file__).resolve().parents[2] / "diagrams" / "multirotor_figure8.py"


def test_both_vehicles_fly_the_figure8_and_the_w_law_tracks_closer_than_lqr(tmp_path):
    spec = importlib.util.spec_from_file_location("multirotor_figure8", SCRIPT)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    result = mod.run(duration=2.5, out_dir=tmp_path)
    for html in result["recordings"].values():
        text = Path(html).read_text(encoding="utf-8")
        assert len(text) > 10_000 and sd.recording_html.external_script_sources(text) == []
    assert set(result["recordings"]) == {"quadrotor", "hexarotor"}
    assert Path(result["plot"]).stat().st_size > 10_000
    rows = result["rows"]
    for name, row in rows.items():
        assert all(math.isfinite(v) for v in row.values()), (name, row)
    for vehicle in ("quadrotor", "hexarotor"):
        # measured at 2.5 s (gust and push squeezed in): 0.07 vs 0.44 m (quadrotor), 0.04 vs
        # 0.42 m (hexarotor)
        assert rows[f"{vehicle} W2/W∞"]["RMS ‖e‖ [m]"] < rows[f"{vehicle} Drake LQR"]["RMS ‖e‖ [m]"]
