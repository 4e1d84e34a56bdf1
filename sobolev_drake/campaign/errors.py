"""What can stop a campaign before or while it runs (the command line exits 2 on each, except
:class:`ClusterLostError`, which happens mid-run with the finished cases on disk: exit 1)."""

from __future__ import annotations

from sobolev_drake.errors import CampaignError

__all__ = ["first_line", "CampaignError", "CampaignFolderError", "CorruptRecordsError",
           "CampaignLockedError", "ClusterUnavailableError", "ClusterLostError"]


class CampaignFolderError(CampaignError, ValueError):
    """A file of the campaign's ``--out`` folder cannot be used as it is (damaged, from another
    version, or describing another campaign).  The message names the file and a way out; the
    folder is left exactly as it was."""


class CorruptRecordsError(CampaignFolderError):
    """``records.jsonl`` holds a line that is not a record (other than a torn last line) or a
    case recorded twice.

    Parameters
    ----------
    message : str
        Names ``file:line`` and the repair command.
    bad : sequence of (int, str)
        (line number, reason) of every bad line; kept as the attribute ``bad``.
    """

    def __init__(self, message, bad=()):
        super().__init__(message)
        self.bad = list(bad)


class CampaignLockedError(CampaignError):
    """Another live process holds the ``--out`` folder."""


class ClusterUnavailableError(CampaignError):
    """The Dask scheduler cannot be reached, or has no workers to start with."""


class ClusterLostError(CampaignError):
    """The Dask cluster lost all its workers mid-run; the finished cases are recorded."""


def first_line(exc: BaseException) -> str:
    """The first line of an exception's message (at most 300 characters), as records and
    messages quote it.

    Parameters
    ----------
    exc : BaseException

    Returns
    -------
    str
    """
    return str(exc).splitlines()[0][:300] if str(exc) else ""
