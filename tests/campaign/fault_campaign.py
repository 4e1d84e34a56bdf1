"""A cheap campaign for the fault-injection tests (no Drake): two synthesized designs whose
"optimum" moves at every solve (as singular LMI optima do), cases that take a few milliseconds.

Importing this module registers it as ``test-faults``; a subprocess runs it inline with
``python fault_campaign.py campaign test-faults ... --workers 0`` (this file as a script forwards
its arguments to the command line), since pool workers would not have it registered.
"""

import os
import sys
import time

import numpy as np

from sobolev_drake.campaign import CampaignDefinition, register_campaign

NAME = "test-faults"
SOLVES = []          # labels synthesized in this process, in order
SPEC = {"gain": 1.0}  # what defines the designs (a test changes it to mimic changed code)


def synthesize(label):
    SOLVES.append(label)
    return {"K": np.full((2, 3), SPEC["gain"] + 1e-4 * len(SOLVES)), "label": label}


def check(label, design):
    if not (isinstance(design, dict) and isinstance(design.get("K"), np.ndarray)
            and design["K"].shape == (2, 3) and np.all(np.isfinite(design["K"]))):
        raise ValueError("K must be a finite 2 × 3 array")


def run(case, design):
    time.sleep(float(os.environ.get("FAULT_CASE_SECONDS", "0")))
    gate = os.environ.get("FAULT_GATE")          # cases after seed 0 wait while the file exists
    t0 = time.monotonic()
    while gate and case.seed > 0 and os.path.exists(gate) and time.monotonic() - t0 < 120:
        time.sleep(0.02)
    return {"indices": {"J": float(design["K"][0, 0]) * (1 + case.seed) / 3.0}, "success": True}


DEFINITION = register_campaign(NAME, CampaignDefinition(
    designs=("A", "B"), indices=("J",), randomizes="nothing", run=run, synthesize=synthesize,
    design_spec=lambda label: {"label": label, **SPEC}, check_design=check))


if __name__ == "__main__":
    from sobolev_drake.cli import main

    sys.exit(main(sys.argv[1:]))
