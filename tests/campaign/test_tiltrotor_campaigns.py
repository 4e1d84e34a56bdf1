"""Campaigns of the tilt-rotor experiments: smoke cases run and carry the declared indices, a
case gives the same record every time, and every design of a seed meets the same disturbances
and parameter draws."""

import math

import pytest

from sobolev_drake.campaign import Case, get_campaign, make_cases, run_case
from sobolev_drake.tiltrotor import campaigns
from sobolev_drake.tiltrotor.mission import scenario_2_phases

HOVER, ENVELOPE = "tiltrotor-hover-linear", "tiltrotor-envelope"
#: the two cheapest Table 7.2 designs (about a second of synthesis each)
CHEAP = ["W∞", "W∞ (disk r=250)"]


def strip(record):
    """The record without what depends on the process running it."""
    return {k: v for k, v in record.items() if k not in ("wall_s", "pid")}


@pytest.fixture(scope="module")
def hover_records():
    cases = make_cases(HOVER, 1, first_seed=4, designs=CHEAP, smoke=True,
                       perturb={"m1": 0.1, "I_C1": 0.1, "sigma": 0.2})
    return cases, [run_case(c) for c in cases]


def test_campaigns_are_declared():
    hover, envelope = get_campaign(HOVER), get_campaign(ENVELOPE)
    from sobolev_drake.tiltrotor.linear_design import DESIGNS
    assert hover.designs == DESIGNS and hover.default_perturb == {}
    assert {"m1", "I_C1", "sigma"} <= set(hover.parameters)
    assert envelope.designs == ("scheduled W∞", "thesis tuning, §7.3.2")
    assert "sigma" not in envelope.parameters
    # one RMS index per mission phase, in the mission file's order
    assert campaigns.ENVELOPE_PHASES == tuple(p[0] for p in scenario_2_phases())


def test_hover_smoke_cases_run_with_the_declared_indices(hover_records):
    cases, recs = hover_records
    for r in recs:
        assert r["success"], r["failure"]
        assert tuple(r["indices"]) == campaigns.HOVER_INDICES
        assert r["indices"]["ISE"] > 0 and r["peaks"]["lateral wind [m/s]"] > 0


def test_hover_designs_of_a_seed_meet_the_same_draws(hover_records):
    cases, recs = hover_records
    a, b = cases
    assert a.design != b.design
    assert recs[0]["perturb_values"] == recs[1]["perturb_values"]
    assert campaigns.hover_turbulence(a) == campaigns.hover_turbulence(b)
    assert campaigns.plant_params(a).m1 == campaigns.plant_params(b).m1 != 7.0
    # the same wind (peak lateral gust), different controllers
    assert recs[0]["peaks"] == recs[1]["peaks"]
    assert recs[0]["indices"] != recs[1]["indices"]
    # another seed: another realization
    other = Case(HOVER, a.design, 5, a.perturb, smoke=True)
    assert campaigns.hover_turbulence(other)[0] != campaigns.hover_turbulence(a)[0]


def test_hover_case_is_reproducible(hover_records):
    cases, recs = hover_records
    assert strip(run_case(cases[0])) == strip(recs[0])


def test_unperturbed_case_flies_the_nominal_plant():
    case = Case(HOVER, "W∞", 0, smoke=True)
    assert campaigns.plant_params(case) is None
    seed, turbulence = campaigns.hover_turbulence(case)
    assert turbulence.sigma == (1.0, 5.0, 3.0) and turbulence.t_on == 0.0
    assert campaigns.hover_turbulence(Case(HOVER, "W∞", 0))[1].t_on == 30.0


def test_a_failed_synthesis_is_a_failed_record_solved_once(monkeypatch):
    from sobolev_drake.tiltrotor import linear_design
    calls = []

    def failing(*args, **kwargs):
        calls.append(1)
        raise ValueError("not solved [LMI path: 37.9 s]")

    monkeypatch.setattr(linear_design, "design", failing)
    monkeypatch.setitem(linear_design.DESIGN_SPECS, "never solved", linear_design.DESIGN_SPECS["W∞"])
    case = Case(HOVER, "never solved", 0, smoke=True)
    first, second = run_case(case), run_case(case)
    # the solve's wall time is not part of the record
    assert first["failure"] == second["failure"] == "synthesis failed: ValueError: not solved"
    assert not first["success"] and first["indices"] == {} and len(calls) == 1


def test_envelope_disturbances_depend_on_the_seed_only():
    a, b = Case(ENVELOPE, "scheduled W∞", 2), Case(ENVELOPE, "another design", 2, smoke=True)
    gusts, forces = campaigns.envelope_disturbances(a)
    assert (gusts, forces) == campaigns.envelope_disturbances(b)
    assert (gusts, forces) != campaigns.envelope_disturbances(Case(ENVELOPE, "scheduled W∞", 3))
    wind = campaigns.envelope_wind(a)
    assert (wind == campaigns.envelope_wind(b)).all() and wind[2] == 0.0
    assert campaigns.WIND_SPEED[0] <= math.hypot(wind[0], wind[1]) <= campaigns.WIND_SPEED[1]
    assert (wind != campaigns.envelope_wind(Case(ENVELOPE, "scheduled W∞", 3))).any()
    assert len(gusts) == 5 and len(forces) == 4
    # durations kept; amplitudes and times drawn around the mission file's
    assert all(e["to"] - e["from"] == pytest.approx(3.0) for e in gusts)
    assert all(e["to"] - e["from"] == pytest.approx(10.0) for e in forces)
    assert 15.0 <= gusts[0]["from"] <= 25.0 and 2.5 <= abs(gusts[0]["value"]) <= 7.5


def test_envelope_smoke_case_runs_and_is_reproducible():
    (case,) = make_cases(ENVELOPE, 1, first_seed=1, smoke=True, perturb={"m1": 0.1, "I_C1": 0.1},
                         designs=["scheduled W∞"])
    first, second = run_case(case), run_case(case)
    assert first["success"], first["failure"]
    assert tuple(first["indices"]) == campaigns.ENVELOPE_INDICES
    assert first["indices"]["RMS accelerate_climb [m]"] > 0
    assert math.isnan(first["indices"]["RMS hold [m]"])      # a phase not reached
    a, b = strip(first), strip(second)
    ia, ib = a.pop("indices"), b.pop("indices")          # NaN != NaN: compare the texts
    assert a == b and repr(ia) == repr(ib)
