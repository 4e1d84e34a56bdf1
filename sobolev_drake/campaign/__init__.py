"""Monte-Carlo campaigns: an experiment's designs × seeds × parameter draws, run in worker
processes or on a Dask cluster, resumable, summarized as distributions and paired comparisons.

``sobolev-drake campaign NAME --seeds N [--workers W] [--scheduler dask-local|ADDRESS]
[--perturb NAME=FRACTION ...] [--resume] --out DIR`` runs one from the command line;
:func:`run_campaign` from Python.  See docs/scale.md for costs and cluster set-up.
"""

from sobolev_drake.campaign.case import CampaignDefinition, Case, DesignFailed
from sobolev_drake.campaign.registry import campaigns, get_campaign, register_campaign
from sobolev_drake.campaign.runner import make_cases, run_campaign, run_case, synthesize_design

__all__ = ["Case", "CampaignDefinition", "DesignFailed", "register_campaign", "get_campaign",
           "campaigns", "make_cases", "synthesize_design", "run_case", "run_campaign"]
