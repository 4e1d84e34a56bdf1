"""The campaign's output folder: its configuration and one record per finished case.

Records are appended to ``records.jsonl`` as soon as a case finishes, one JSON line each,
written in one call and flushed to disk, so a killed worker or machine loses only the cases in
flight.  A trailing partial line (the process died while writing it) is dropped when the file is
reopened.  ``campaign.json`` holds what defines the cases; resuming with a different
definition is refused.  ``designs.pkl`` pins the synthesized designs of a campaign that declares
``synthesize`` (:meth:`CampaignStore.load_designs`): a resume flies the same controllers.
"""

from __future__ import annotations

import json
import os
import pickle
from pathlib import Path

__all__ = ["CampaignStore"]

RECORDS = "records.jsonl"
CONFIG = "campaign.json"
DESIGNS = "designs.pkl"


class CampaignStore:
    """Records and configuration of one campaign in ``out_dir``.

    Parameters
    ----------
    out_dir : str or Path
        The campaign's folder (created).
    """

    def __init__(self, out_dir):
        self.dir = Path(out_dir)
        self.dir.mkdir(parents=True, exist_ok=True)
        self.records_path = self.dir / RECORDS
        self.config_path = self.dir / CONFIG
        self.designs_path = self.dir / DESIGNS

    def start(self, config: dict, *, resume: bool) -> dict:
        """Begin (or resume) a campaign with ``config``; returns the records already done.

        Parameters
        ----------
        config : dict
            What defines the cases (campaign, designs, perturbations, duration, smoke); the
            seed range may grow between runs.
        resume : bool
            Continue the records in the folder.  Without it a folder that already holds
            records is refused (nothing is overwritten).

        Returns
        -------
        dict
            {case key: record} of the finished cases (empty when not resuming).
        """
        done = self.load()
        if not resume:
            if done:
                raise FileExistsError(f"{self.records_path} already holds {len(done)} records; "
                                      "pass --resume to continue it, or choose another --out")
            self.records_path.write_text("", encoding="utf-8")
            self.designs_path.unlink(missing_ok=True)     # a new campaign synthesizes anew
        elif self.config_path.exists():
            old = json.loads(self.config_path.read_text(encoding="utf-8"))
            fixed = ("campaign", "designs", "perturb", "duration", "smoke")
            diff = [k for k in fixed if old.get(k) != config.get(k)]
            if diff:
                raise ValueError(f"--resume with a different campaign definition ({', '.join(diff)}: "
                                 f"{[old.get(k) for k in diff]} before, {[config.get(k) for k in diff]} now)")
        self.config_path.write_text(json.dumps(config, indent=2), encoding="utf-8")
        return done

    def load(self) -> dict:
        """{case key: record} of every complete line; a trailing partial line is removed.

        Returns
        -------
        dict
        """
        if not self.records_path.exists():
            return {}
        raw = self.records_path.read_bytes()
        out, good = {}, 0
        for line in raw.splitlines(keepends=True):
            if not line.endswith(b"\n"):
                break
            try:
                rec = json.loads(line)
            except json.JSONDecodeError:
                break
            if rec["key"] in out:
                raise ValueError(f"{self.records_path}: case {rec['key']} recorded twice")
            out[rec["key"]] = rec
            good += len(line)
        if good < len(raw):                       # died while writing: drop the fragment
            with open(self.records_path, "r+b") as f:
                f.truncate(good)
        return out

    def append(self, record: dict) -> None:
        """Write one finished case (one line, flushed and synced).

        Parameters
        ----------
        record : dict
            JSON-serializable record with a "key".
        """
        line = (json.dumps(record, allow_nan=True) + "\n").encode("utf-8")
        with open(self.records_path, "ab") as f:
            f.write(line)
            f.flush()
            os.fsync(f.fileno())

    def load_designs(self) -> dict:
        """The pinned designs, {label: {"design": object} or {"failure": str}} (empty if none).

        Returns
        -------
        dict
        """
        if not self.designs_path.exists():
            return {}
        with open(self.designs_path, "rb") as f:
            pinned = pickle.load(f)
        if not isinstance(pinned, dict):
            raise ValueError(f"{self.designs_path} does not hold a campaign's designs")
        return pinned

    def save_designs(self, pinned: dict) -> None:
        """Pin ``pinned`` (as :meth:`load_designs` returns it), replacing the file atomically.

        Parameters
        ----------
        pinned : dict
        """
        tmp = self.designs_path.with_suffix(".tmp")
        with open(tmp, "wb") as f:
            pickle.dump(pinned, f, protocol=pickle.HIGHEST_PROTOCOL)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, self.designs_path)
