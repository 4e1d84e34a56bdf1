"""The campaigns experiments declare, by experiment name.

An experiment module calls :func:`register_campaign` next to its ``@register``; the campaign
runner finds them with :func:`get_campaign`, which imports the experiment modules the way the
CLI does (by name, at run time), so this package never imports an experiment.
"""

from __future__ import annotations

import importlib

from sobolev_drake.errors import CampaignError

from sobolev_drake.campaign.case import CampaignDefinition

__all__ = ["register_campaign", "get_campaign", "campaigns", "UnknownCampaignError"]

_CAMPAIGNS: dict = {}


class UnknownCampaignError(CampaignError, KeyError):
    """No experiment of that name declares a campaign."""

    def __str__(self):  # KeyError quotes its message
        return self.args[0]


def register_campaign(name: str, definition: CampaignDefinition) -> CampaignDefinition:
    """Declare ``definition`` as the campaign of experiment ``name``.

    Parameters
    ----------
    name : str
        The experiment's registered name.
    definition : CampaignDefinition
        Its designs, randomness, parameters and case runner.

    Returns
    -------
    CampaignDefinition
        ``definition``.
    """
    if not isinstance(definition, CampaignDefinition):
        raise TypeError(f"definition must be a CampaignDefinition, got {type(definition).__name__}")
    if name in _CAMPAIGNS and _CAMPAIGNS[name] is not definition:
        raise ValueError(f"campaign {name!r} registered twice")
    _CAMPAIGNS[name] = definition
    return definition


def campaigns() -> dict:
    """Every declared campaign, {experiment name: CampaignDefinition}.

    Returns
    -------
    dict
    """
    importlib.import_module("sobolev_drake.experiments").discover()
    return dict(_CAMPAIGNS)


def get_campaign(name: str) -> CampaignDefinition:
    """The campaign of experiment ``name``.

    Parameters
    ----------
    name : str
        A registered experiment name.

    Returns
    -------
    CampaignDefinition
    """
    if name not in _CAMPAIGNS:
        known = campaigns()
        if name not in known:
            raise UnknownCampaignError(f"no campaign {name!r}; experiments with a campaign: "
                                       f"{', '.join(sorted(known)) or '(none)'}")
    return _CAMPAIGNS[name]
