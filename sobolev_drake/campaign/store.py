"""The campaign's output folder: its definition, its pinned designs and one record per case.

Files of a folder ``DIR`` (docs/reliability.md states what survives what):

``records.jsonl``
    Append-only, one JSON line per finished case.  Each line is written with one ``write`` on a
    file opened for appending, then flushed and ``fsync``-ed before the case counts as done, so
    a killed worker, campaign or machine loses only the cases in flight.  A write that fails
    (full disk) is cut back to the last whole line before the error is raised.  Reading never
    deletes a record: only an unterminated last fragment (the process died mid-write) is set
    aside, into ``records.torn``; any other line that is not a record, or a case recorded twice,
    stops the run with ``file:line`` and the way out (:meth:`CampaignStore.repair`, ``sobolev-drake
    campaign-repair DIR``), which moves such lines to ``records.rejected.jsonl``.
``campaign.json``
    What defines the cases (campaign, designs, perturbations, duration, smoke); a resume with a
    different definition, or with records but no definition, is refused.
``designs.json``
    The pinned designs of a campaign that declares ``synthesize``: JSON with typed arrays
    (:mod:`sobolev_drake.datafile`), never pickle, with a schema version, the campaign's name,
    a fingerprint of each design's specification and a checksum of the content.  A design that
    is a :class:`~sobolev_drake.synthesis.problem.SynthesisResult` is stored in the design-file
    encoding (:func:`~sobolev_drake.synthesis.design_file.encode_result`, with its own result
    schema) under ``"result"``, any other design as data under ``"design"``.  Written
    atomically (temporary file, fsync, rename, folder fsync).  Schema 1 (before results were
    stored as results) is refused with the way out: its designs cannot be flown as this
    version's designs.
``runs.jsonl``
    One line per run: start time, wall time, cases run, executor (the summary holds none of it,
    so that it depends on the records alone).
``.lock``
    Held (``flock``) by the one process running the campaign, with its pid, host and start time
    inside; the kernel releases it when that process dies, however it dies.
"""

from __future__ import annotations

import contextlib
import datetime
import json
import os
import socket
import sys
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

from sobolev_drake.campaign.errors import (CampaignFolderError, CampaignLockedError,
                                           CorruptRecordsError)
from sobolev_drake.datafile import (DataFileError, fingerprint, from_tree, fsync_directory,
                                    read_json, to_tree, write_bytes_atomic, write_json_atomic)

__all__ = ["CampaignStore", "DESIGNS_FORMAT", "DESIGNS_SCHEMA"]

RECORDS = "records.jsonl"
CONFIG = "campaign.json"
DESIGNS = "designs.json"
LEGACY_DESIGNS = "designs.pkl"
LOCK = ".lock"
TORN = "records.torn"
REJECTED = "records.rejected.jsonl"
RUNS = "runs.jsonl"

DESIGNS_FORMAT = "sobolev_drake campaign designs"
DESIGNS_SCHEMA = 2
#: why an older designs schema is refused: its designs are not what this version flies
OLD_DESIGNS = {1: "pinned before synthesis results were stored as results"}
#: what defines a campaign's cases: a resume must match them
DEFINING_KEYS = ("campaign", "designs", "perturb", "duration", "smoke")
_REPAIR = "sobolev-drake campaign-repair {dir}"


def _record_problem(line: bytes):
    """(record, None) for a well-formed record line, else (None, reason)."""
    if b"\x00" in line:
        return None, "NUL bytes (damaged on disk)"
    try:
        rec = json.loads(line.decode("utf-8"))
    except UnicodeDecodeError:
        return None, "not UTF-8 text"
    except json.JSONDecodeError as exc:
        return None, f"not JSON ({exc.msg} at column {exc.colno})"
    if not isinstance(rec, dict):
        return None, f"a JSON {type(rec).__name__}, not a record"
    missing = [k for k in ("key", "design", "seed", "success") if k not in rec]
    if missing:
        return None, f"a record without {', '.join(missing)}"
    if not (isinstance(rec["design"], str) and isinstance(rec["seed"], int)
            and not isinstance(rec["seed"], bool) and isinstance(rec["success"], bool)):
        return None, "a record whose design, seed or success has the wrong type"
    if rec["key"] != f"{rec['design']}|{rec['seed']}":
        return None, f"a record whose key {rec['key']!r} is not its design|seed"
    return rec, None


def _append_synced(path, data: bytes, expect_size=None) -> None:
    """Append ``data`` to ``path`` with unbuffered writes and fsync; on failure (a full disk)
    cut the file back to its size before, so no partial line is left for the next append."""
    # unbuffered: a failed write leaves no buffered remainder for close() to write later
    fd = os.open(path, os.O_WRONLY | os.O_APPEND | os.O_CREAT, 0o644)
    try:
        size = os.fstat(fd).st_size
        if expect_size is not None and size != expect_size:
            raise RuntimeError(f"{path} changed while it was read")
        try:
            view = memoryview(data)
            while view:
                view = view[os.write(fd, view):]
            os.fsync(fd)
        except BaseException:
            with contextlib.suppress(OSError):
                os.ftruncate(fd, size)
            raise
    finally:
        os.close(fd)


class CampaignStore:
    """Records, definition and pinned designs of one campaign in ``out_dir``.

    Parameters
    ----------
    out_dir : str or Path
        The campaign's folder (created if missing).  The empty string is refused (it would
        mean the current folder).

    Examples
    --------
    >>> import tempfile
    >>> with tempfile.TemporaryDirectory() as folder:
    ...     store = CampaignStore(folder)
    ...     with store.locked():
    ...         done = store.start({"campaign": "c", "designs": ["A"], "perturb": [],
    ...                             "duration": None, "smoke": True}, resume=False)
    ...         store.append({"key": "A|0", "design": "A", "seed": 0, "success": True})
    ...         sorted(store.load())
    ['A|0']
    """

    def __init__(self, out_dir):
        if not isinstance(out_dir, (str, os.PathLike)) or str(out_dir).strip() == "":
            raise ValueError(f"out_dir must name a folder, got {out_dir!r} (use '.' for the "
                             "current folder)")
        self.dir = Path(out_dir)
        try:
            self.dir.mkdir(parents=True, exist_ok=True)
        except FileExistsError:
            raise CampaignFolderError(f"--out {self.dir}: exists and is not a folder") from None
        self.records_path = self.dir / RECORDS
        self.config_path = self.dir / CONFIG
        self.designs_path = self.dir / DESIGNS
        self.legacy_designs_path = self.dir / LEGACY_DESIGNS
        self.lock_path = self.dir / LOCK
        self.torn_path = self.dir / TORN
        self.rejected_path = self.dir / REJECTED
        self._lock_fd = None

    # -- the lock ---------------------------------------------------------------------------

    @contextlib.contextmanager
    def locked(self) -> Iterator[CampaignStore]:
        """Hold the folder for this process (non-blocking ``flock`` on ``.lock``).

        Yields
        ------
        CampaignStore
            This store, which may then start, append, repair and pin designs.

        Raises
        ------
        CampaignLockedError
            Another live process holds it; the message names that process.
        """
        import fcntl

        fd = os.open(self.lock_path, os.O_RDWR | os.O_CREAT, 0o644)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            holder = os.pread(fd, 4096, 0).decode("utf-8", "replace").strip() or "unknown process"
            os.close(fd)
            raise CampaignLockedError(
                f"--out {self.dir} is in use by another campaign ({holder}); wait for it to "
                "finish, stop it, or choose another --out") from None
        except BaseException:
            os.close(fd)
            raise
        try:
            now = datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds")
            info = f"pid {os.getpid()} on {socket.gethostname()}, since {now}\n".encode()
            os.ftruncate(fd, 0)
            os.pwrite(fd, info, 0)
            self._lock_fd = fd
            yield self
        finally:
            self._lock_fd = None
            os.close(fd)                        # releases the flock

    def _require_lock(self, what):
        if self._lock_fd is None:
            raise RuntimeError(f"CampaignStore.{what} needs the folder's lock (use `with store.locked():`)")

    # -- definition ------------------------------------------------------------------------

    def start(self, config: dict, *, resume: bool) -> dict:
        """Begin (or resume) a campaign with ``config``; returns the records already done.

        Parameters
        ----------
        config : dict
            What defines the cases (:data:`DEFINING_KEYS`); the seed range may grow between
            runs.
        resume : bool
            Continue the campaign in the folder.  Without it a folder that holds records or
            pinned designs is refused (nothing is overwritten).

        Returns
        -------
        dict
            {case key: record} of the finished cases (empty when not resuming).

        Raises
        ------
        FileExistsError
            Not resuming, and the folder already holds a campaign.
        CampaignFolderError
            Resuming with another definition, without the definition file, or with damaged
            files (naming the file).
        """
        self._require_lock("start")
        has_records = self.records_path.exists() and self.records_path.stat().st_size > 0
        pinned = [p for p in (self.designs_path, self.legacy_designs_path) if p.exists()]
        if not resume:
            if has_records or pinned:
                lines = self.records_path.read_bytes().count(b"\n") if has_records else 0
                what = (f"{self.records_path} already holds {lines} record line(s)"
                        if has_records else f"{pinned[0]} already pins designs")
                raise FileExistsError(f"{what}; pass --resume to continue that campaign, or "
                                      "choose another --out")
        elif self.config_path.exists():
            old = self._read_config()
            diff = [k for k in DEFINING_KEYS if old.get(k) != config.get(k)]
            if diff:
                raise CampaignFolderError(
                    f"{self.config_path}: --resume with a different campaign definition ("
                    + "; ".join(f"{k}: {old.get(k)!r} before, {config.get(k)!r} now" for k in diff)
                    + "); resume with the original options, or choose another --out")
        elif has_records or pinned:
            raise CampaignFolderError(
                f"{self.config_path} is missing, but the folder holds "
                f"{'records' if has_records else 'pinned designs'} flown with a definition that "
                "is now unknown; restore the file, or choose another --out")
        done = self.load() if resume else {}
        bad = [k for k, r in done.items() if r.get("campaign", config["campaign"]) != config["campaign"]
               or r["design"] not in config["designs"]]
        if bad:
            raise CampaignFolderError(f"{self.records_path}: record {bad[0]!r} belongs to another "
                                      f"campaign or design than {config['campaign']!r} "
                                      f"{config['designs']}; choose another --out")
        if not self.records_path.exists():
            self.records_path.touch()
            fsync_directory(self.dir)
        write_json_atomic(self.config_path, config)
        return done

    def _read_config(self) -> dict:
        try:
            old = read_json(self.config_path, "the campaign definition")
        except DataFileError as exc:
            raise CampaignFolderError(f"{exc}; restore it, or choose another --out") from None
        if not isinstance(old, dict) or not set(DEFINING_KEYS) <= set(old):
            raise CampaignFolderError(f"{self.config_path}: not a campaign definition (needs "
                                      f"{', '.join(DEFINING_KEYS)}); restore it, or choose another --out")
        return old

    # -- records ---------------------------------------------------------------------------

    def _scan(self):
        """(raw bytes, [(line number, line bytes incl. newline, record or None, reason)],
        unterminated fragment)."""
        raw = self.records_path.read_bytes() if self.records_path.exists() else b""
        parts = raw.split(b"\n")
        fragment = parts.pop()
        lines, first = [], {}
        for number, body in enumerate(parts, start=1):
            rec, reason = _record_problem(body)
            if rec is not None and rec["key"] in first:
                rec, reason = None, f"case {rec['key']} already recorded on line {first[rec['key']]}"
            elif rec is not None:
                first[rec["key"]] = number
            lines.append((number, body + b"\n", rec, reason))
        return raw, lines, fragment

    def load(self) -> dict:
        """{case key: record} of every record line.

        An unterminated last fragment (the process died while writing it) is moved to
        ``records.torn`` when this process holds the lock (a complete record merely missing its
        newline is kept and terminated); nothing else is ever removed.

        Returns
        -------
        dict

        Raises
        ------
        CorruptRecordsError
            A line that is not a record, or a case recorded twice: the message gives
            ``file:line`` and the repair command; the file is left untouched.
        """
        raw, lines, fragment = self._scan()
        bad = [(n, reason) for n, _, rec, reason in lines if rec is None]
        if bad:
            shown = "; ".join(f"{self.records_path}:{n}: {reason}" for n, reason in bad[:3])
            more = f" (and {len(bad) - 3} more)" if len(bad) > 3 else ""
            raise CorruptRecordsError(
                f"{shown}{more}. {len(bad)} of {len(lines)} line(s) are not usable records and "
                "nothing was changed; run `" + _REPAIR.format(dir=self.dir) + "` to move them "
                f"to {REJECTED} (the records around them are kept), then resume", bad)
        out = {rec["key"]: rec for _, _, rec, _ in lines}
        if fragment and self._lock_fd is not None:
            rec, _ = _record_problem(fragment)
            if rec is not None and rec["key"] not in out:
                _append_synced(self.records_path, b"\n", expect_size=len(raw))     # only the newline was lost
                out[rec["key"]] = rec
            else:
                self._set_aside(fragment, len(raw) - len(fragment))
        return out

    def _set_aside(self, fragment: bytes, keep: int):
        _append_synced(self.torn_path, fragment + b"\n")   # copy first: nothing lost if we die here
        with open(self.records_path, "r+b") as f:
            f.truncate(keep)
            f.flush()
            os.fsync(f.fileno())
        print(f"sobolev-drake: {self.records_path}: an unterminated last line ({len(fragment)} "
              f"bytes, a write cut short) was moved to {self.torn_path}", file=sys.stderr)

    def append(self, record: dict) -> None:
        """Write one finished case: one line, flushed and synced before returning.

        Parameters
        ----------
        record : dict
            JSON-serializable record with "key", "design", "seed" and "success".

        Raises
        ------
        OSError
            The write failed (e.g. a full disk); the file is cut back to its last whole line.
        """
        line = (json.dumps(record, allow_nan=True) + "\n").encode("utf-8")
        _append_synced(self.records_path, line)


    def repair(self) -> dict:
        """Move every line that is not a usable record (and later copies of a case recorded
        twice) to ``records.rejected.jsonl``; keep the others in order.

        The rejected lines are written (as ``{"line", "reason", "text"}``) and synced before
        ``records.jsonl`` is replaced atomically by the kept ones: nothing is lost if the
        process dies on the way.

        Returns
        -------
        dict
            "kept", "rejected" (counts) and "side_file" (path, or None when nothing moved).
        """
        self._require_lock("repair")
        raw, lines, fragment = self._scan()
        rejected = [(n, reason, body) for n, body, rec, reason in lines if rec is None]
        if fragment:
            rejected.append((len(lines) + 1, "unterminated last line", fragment))
        kept = [body for _, body, rec, _ in lines if rec is not None]
        if not rejected:
            return {"kept": len(kept), "rejected": 0, "side_file": None}
        _append_synced(self.rejected_path, b"".join(
            (json.dumps({"line": n, "reason": reason,
                         "text": body.rstrip(b"\n").decode("utf-8", "backslashreplace")}) + "\n").encode()
            for n, reason, body in rejected))
        write_bytes_atomic(self.records_path, b"".join(kept))
        return {"kept": len(kept), "rejected": len(rejected), "side_file": str(self.rejected_path)}

    def log_run(self, entry: dict) -> None:
        """Append one line about this run (when, how long, where) to ``runs.jsonl``: the run's
        metadata lives there, so that ``summary.json`` depends on the records alone.

        Parameters
        ----------
        entry : dict
        """
        _append_synced(self.dir / RUNS, (json.dumps(entry) + "\n").encode("utf-8"))

    # -- pinned designs --------------------------------------------------------------------

    def load_designs(self, campaign: str, specs: dict,
                     check: Callable[..., Any] | None = None) -> dict:
        """The pinned designs, validated: {label: {"design": object} or {"failure": str}}.

        Parameters
        ----------
        campaign : str
            The campaign the folder must belong to.
        specs : dict
            {label: specification fingerprint} of the designs as the code defines them now
            (:func:`sobolev_drake.datafile.fingerprint`); a pinned design whose specification
            changed is refused.
        check : callable, optional
            ``check(label, design)`` raising ``ValueError``/``TypeError`` when a design is not
            of the structure ``synthesize`` produces.

        Returns
        -------
        dict
            Empty when no design is pinned yet.

        Raises
        ------
        CampaignFolderError
            A legacy pickle (never loaded), a damaged or edited file, another campaign's file,
            a changed specification or a design of the wrong structure; the message names the
            file and the problem.
        """
        if self.legacy_designs_path.exists():
            raise CampaignFolderError(
                f"{self.legacy_designs_path}: designs pinned as a pickle by an older version are "
                "never loaded (a pickle can run code); choose another --out, or delete the file "
                "and its records to start this campaign anew")
        if not self.designs_path.exists():
            return {}
        path = self.designs_path
        try:
            doc = read_json(path, "the pinned designs")
        except DataFileError as exc:
            raise CampaignFolderError(f"{exc}; restore it, or choose another --out") from None

        def refuse(why):
            return CampaignFolderError(f"{path}: {why}; restore the file, or choose another --out")

        if not isinstance(doc, dict) or doc.get("format") != DESIGNS_FORMAT:
            raise refuse(f"not a campaign's designs file (no format {DESIGNS_FORMAT!r})")
        if doc.get("schema") != DESIGNS_SCHEMA:
            old = OLD_DESIGNS.get(doc.get("schema")) if type(doc.get("schema")) is int else None
            raise refuse(f"schema {doc.get('schema')!r}, this version reads schema {DESIGNS_SCHEMA}"
                         + (f" ({old})" if old else ""))
        if doc.get("campaign") != campaign:
            raise refuse(f"pins the designs of campaign {doc.get('campaign')!r}, not {campaign!r}")
        designs = doc.get("designs")
        if not isinstance(designs, dict) or doc.get("checksum") != fingerprint(designs):
            raise refuse("its content does not match its checksum (edited or damaged after it "
                         "was written)")
        pinned = {}
        for label, entry in designs.items():
            if label not in specs:
                raise refuse(f"pins design {label!r}, which campaign {campaign!r} does not have")
            if not (isinstance(entry, dict) and "spec" in entry and len(entry) == 2
                    and ("design" in entry or "result" in entry
                         or isinstance(entry.get("failure"), str))):
                raise refuse(f"design {label!r} is neither a design nor a failure")
            if entry["spec"] != specs[label]:
                raise refuse(f"the specification of design {label!r} has changed since it was "
                             "pinned (the library or the campaign's code changed), so its records "
                             "were flown with another controller")
            if "failure" in entry:
                pinned[label] = {"failure": entry["failure"]}
                continue
            design = entry["design"] if "design" in entry else _decode_result(entry["result"], label, refuse)
            if check is not None:
                try:
                    check(label, design)
                except (TypeError, ValueError) as exc:
                    raise refuse(f"design {label!r} is not what the synthesis produces ({exc})") from None
            pinned[label] = {"design": design}
        return pinned

    def save_designs(self, campaign: str, pinned: dict, specs: dict) -> None:
        """Pin ``pinned`` (as :meth:`load_designs` returns it), replacing the file atomically.

        Parameters
        ----------
        campaign : str
        pinned : dict
            {label: {"design": value} or {"failure": str}}; each design is a
            ``SynthesisResult`` (stored in the design-file encoding) or storable as data
            (:func:`sobolev_drake.datafile.to_tree`: numbers, strings, lists, dicts, arrays).
        specs : dict
            {label: specification fingerprint}.
        """
        self._require_lock("save_designs")
        designs = {label: {"spec": specs[label], **({"failure": str(entry["failure"])}
                                                    if "failure" in entry else _encode(entry["design"]))}
                   for label, entry in pinned.items()}
        # the checksum is taken on exactly what a reader will decode
        designs = from_tree(json.loads(json.dumps(to_tree(designs), allow_nan=True)))
        write_json_atomic(self.designs_path, {
            "format": DESIGNS_FORMAT, "schema": DESIGNS_SCHEMA, "campaign": campaign,
            "designs": designs, "checksum": fingerprint(designs)})


def _encode(design) -> dict:
    """The entry of one pinned design: a synthesis result in the design-file encoding (with
    its result schema), anything else as data."""
    from sobolev_drake.synthesis.design_file import RESULT_SCHEMA, encode_result
    from sobolev_drake.synthesis.problem import SynthesisResult

    if isinstance(design, SynthesisResult):
        return {"result": {"schema": RESULT_SCHEMA, "fields": encode_result(design)}}
    return {"design": design}


def _decode_result(entry, label, refuse):
    """The SynthesisResult of a ``"result"`` entry, or ``refuse``'s error naming the design."""
    from sobolev_drake.synthesis.design_file import decode_result

    if not (isinstance(entry, dict) and set(entry) == {"schema", "fields"}):
        raise refuse(f"design {label!r} is not a pinned synthesis result (schema and fields)")
    try:
        return decode_result(entry["fields"], f"design {label!r}", entry["schema"])
    except DataFileError as exc:
        raise refuse(str(exc)) from None
