"""Run FE evaluations of many designs through an executor, cached on disk.

The evaluator is any picklable top-level callable ``evaluate(design, settings)
-> dict`` (for the FE model: ``fem.batch.evaluate_design``, which this package
must not import; the caller passes it in). Each result is stored as soon as it
arrives, one JSON file per design, so an interrupted run resumes where it
stopped. Records have the form::

    {"key": sha256 hex, "design": {...}, "settings": {...}, "result": {...}, "sha256": hex}

where ``sha256`` is the checksum of the rest (:mod:`isj.cachefile`), verified on
every read. An evaluator that names the result families it computes (a
``result_families`` attribute, as :func:`isj.fem.batch.evaluate_design` does) has
their versions (:func:`isj.results_version.versions`) put into the settings, hence
into every key: a cached FE result is found again after any change of the code that
leaves its family's version, and never after one that bumps it
(docs/developer/cache-keys.md).

Workers are started with the ``spawn`` method: a forked child of a process
that has already run MKL/OpenMP code (PARDISO) or holds threads (Dask, tqdm)
can deadlock. Scripts that call :func:`run_designs` therefore need the usual
``if __name__ == "__main__":`` guard.
"""

from __future__ import annotations

import hashlib
import json
import math
import multiprocessing
import os
from collections.abc import Callable, Mapping, Sequence
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from pathlib import Path

from tqdm.auto import tqdm

from isj.cachefile import DamagedEntry, discard, read_json_entry, write_json_entry
from isj.errors import EvaluationError
from isj.results_version import versions

RECORD_FIELDS = ("key", "design", "settings", "result")


def _canonical(obj, where: str = "value"):
    """JSON-ready copy: str keys, lists for sequences, plain int/float (finite), str, bool, None."""
    if isinstance(obj, Mapping):
        out = {}
        for k, v in obj.items():
            if not isinstance(k, str):
                raise TypeError(f"{where}: key {k!r} is not a string")
            out[k] = _canonical(v, f"{where}[{k!r}]")
        return out
    if isinstance(obj, list | tuple):
        return [_canonical(v, f"{where}[{i}]") for i, v in enumerate(obj)]
    if hasattr(obj, "dtype") and getattr(obj, "shape", None) == ():  # numpy scalar → Python
        obj = obj.item()
    if isinstance(obj, str | bool) or obj is None:
        return obj
    if isinstance(obj, int):
        return int(obj)
    if isinstance(obj, float):
        if not math.isfinite(obj):
            raise ValueError(f"{where} = {obj!r}: not a finite number")
        return float(obj)
    raise TypeError(f"{where} = {obj!r}: not JSON-able (type {type(obj).__name__})")


def _canonical_design(design: Mapping) -> dict[str, float]:
    # moduli are floats: 5e9 and 5_000_000_000 are the same design and get the same key
    out = _canonical(design, "design")
    for k, v in out.items():
        if isinstance(v, bool) or not isinstance(v, int | float):
            raise TypeError(f"design[{k!r}] = {v!r}: must be a number")
        out[k] = float(v)
    return out


def _dumps(obj) -> str:
    # json writes floats with float.__repr__: shortest string that round-trips exactly
    return json.dumps(obj, sort_keys=True, separators=(",", ":"), allow_nan=False)


def design_key(design: Mapping, settings: Mapping) -> str:
    """sha256 (hex) of the canonical JSON of ``{"design": ..., "settings": ...}``.

    Canonical: sorted keys, no whitespace, floats written with ``repr`` (exact),
    numeric design values as floats; non-finite numbers are rejected.
    """
    payload = {"design": _canonical_design(design), "settings": _canonical(settings, "settings")}
    return hashlib.sha256(_dumps(payload).encode()).hexdigest()


def keyed_settings(evaluate: Callable, settings: Mapping) -> dict:
    """Canonical ``settings`` with the results versions of what ``evaluate`` computes.

    ``evaluate.result_families`` (a tuple of family names of :mod:`isj.results_version`)
    gives ``settings["versions"] = versions(*families)``, replacing any there; an evaluator
    without it gets ``settings`` unchanged.
    """
    out = _canonical(settings, "settings")
    families = getattr(evaluate, "result_families", None)
    if families:
        out["versions"] = versions(*families)
    return out


class ResultCache:
    """Directory of records, one ``<key>.json`` per design, written atomically.

    A record that cannot be read or parsed, holds non-finite numbers, fails its
    checksum, misses fields or does not match its key is reported with one
    :class:`CorruptCacheEntry` warning line, deleted and treated as missing: never used.
    """

    def __init__(self, directory: str | os.PathLike):
        self.directory = Path(directory)
        self.directory.mkdir(parents=True, exist_ok=True)

    def path(self, key: str) -> Path:
        return self.directory / f"{key}.json"

    def get(self, key: str) -> dict | None:
        """The record stored under ``key``, or None if absent or damaged."""
        path = self.path(key)
        try:
            record = read_json_entry(path, finite=True)
            if record is not None:
                self._check(key, record)
        except DamagedEntry as exc:
            discard(path, "FE result", str(exc), stacklevel=2)
            return None
        return record

    @staticmethod
    def _check(key: str, record: dict) -> None:
        """DamagedEntry unless ``record`` is a whole record that belongs under ``key``."""
        if set(record) != set(RECORD_FIELDS):
            raise DamagedEntry(f"fields {sorted(record)}, expected {sorted(RECORD_FIELDS)}")
        if record["key"] != key:
            raise DamagedEntry(f"stored key {record['key']!r} differs from the file name")
        if not isinstance(record["result"], dict):
            raise DamagedEntry("result is not an object")
        try:
            if design_key(record["design"], record["settings"]) != key:
                raise DamagedEntry("design and settings do not hash to the key")
        except (TypeError, ValueError, AttributeError) as exc:  # not a design or settings at all
            raise DamagedEntry(f"design or settings unusable ({exc})") from exc

    def put(self, key: str, design: Mapping, settings: Mapping, result: Mapping) -> dict:
        """Store a record atomically, with its checksum; return it as it reads back (plain JSON types)."""
        record = {
            "key": key,
            "design": _canonical_design(design),
            "settings": _canonical(settings, "settings"),
            "result": _canonical(result, "result"),
        }
        return write_json_entry(self.path(key), record)


def _client_for(scheduler):
    """(client, owned): a Dask client for an address string or an existing client."""
    if isinstance(scheduler, str):
        from distributed import Client  # lazy: dask is slow to import and optional here

        return Client(scheduler), True
    if hasattr(scheduler, "submit") and hasattr(scheduler, "cancel"):
        return scheduler, False
    raise TypeError(f"scheduler = {scheduler!r}: must be an address string or a distributed.Client")


def run_designs(
    designs: Sequence[Mapping],
    evaluate: Callable[[dict, dict], Mapping],
    settings: Mapping,
    cache_dir: str | os.PathLike,
    scheduler=None,
    max_workers: int | None = None,
    progress: bool = True,
) -> list[dict]:
    """Evaluate ``designs`` (skipping cached ones) and return their records in order.

    Parameters
    ----------
    designs : sequence of dict
        Moduli (Pa) per design, e.g. from :func:`calibration.doe.sample`.
        Duplicates are evaluated once.
    evaluate : callable
        Picklable top-level ``evaluate(design, settings) -> dict`` returning
        JSON-able finite numbers (SI units).
    settings : dict
        Evaluation settings shared by all designs (JSON-able); part of each key, with the
        results versions of ``evaluate``'s families (:func:`keyed_settings`).
    cache_dir : path
        Directory of the :class:`ResultCache`.
    scheduler : None, str or distributed.Client
        None: a local ``ProcessPoolExecutor``. An address such as
        ``"tcp://127.0.0.1:8786"`` or a client: Dask distributed (the cluster
        decides the parallelism; ``max_workers`` is ignored).
    max_workers : int, optional
        Worker processes of the local pool; default 1, since each FE solve
        already uses every core (PARDISO) and a model holds its matrices.
        0 evaluates in this process, one design after the other: no worker
        start-up, and models memoised by ``evaluate`` stay for the caller's next run.
    progress : bool
        Show a tqdm bar on stderr (only when it is a terminal).

    Returns
    -------
    list of dict
        ``{"key", "design", "settings", "result"}`` per design, in input order.

    Raises
    ------
    EvaluationError
        If any evaluation raised or returned something that cannot be stored.
        It names the designs; every other result has been cached first.
    """
    settings = keyed_settings(evaluate, settings)
    designs = [_canonical_design(d) for d in designs]
    keys = [design_key(d, settings) for d in designs]
    cache = ResultCache(cache_dir)
    records, todo = _cached_and_todo(cache, keys, designs)
    failures = (
        _evaluate(todo, records, cache, evaluate, settings, scheduler, max_workers, progress) if todo else []
    )
    if failures:
        lines = [f"  {d}: {type(e).__name__}: {e}" for d, e in failures]
        raise EvaluationError(
            f"{len(failures)} of {len(todo)} design(s) failed (the others are cached in {cache.directory}):\n"
            + "\n".join(lines),
            failures,
        ) from failures[0][1]
    return [records[k] for k in keys]


def _cached_and_todo(cache: ResultCache, keys: list[str], designs: list[dict]) -> tuple[dict, dict]:
    """(key → cached record, key → design to evaluate), each distinct key once, in input order."""
    records: dict[str, dict] = {}
    todo: dict[str, dict] = {}
    for key, design in zip(keys, designs, strict=True):
        if key in records or key in todo:
            continue
        rec = cache.get(key)
        if rec is None:
            todo[key] = design
        else:
            records[key] = rec
    return records, todo


def _evaluate(
    todo: dict[str, dict],
    records: dict[str, dict],
    cache: ResultCache,
    evaluate: Callable,
    settings: dict,
    scheduler,
    max_workers: int | None,
    progress: bool,
) -> list[tuple[dict, BaseException]]:
    """Evaluate ``todo`` (key → design) here, on a local pool or on Dask, with a progress bar.

    Each result is cached and added to ``records`` as it arrives. Returns the failures,
    ``(design, exception)`` for each evaluation that raised or returned something other than a
    dict; the others go on.
    """
    failures: list[tuple[dict, BaseException]] = []
    bar = tqdm(
        total=len(todo),
        desc="FE designs",
        unit="design",
        disable=None if progress else True,
        postfix={"cached": len(records)},
    )
    try:

        def store(key: str, outcome: Callable[[], Mapping]) -> None:
            try:
                result = outcome()
                if not isinstance(result, Mapping):
                    raise TypeError(f"evaluate returned {type(result).__name__}, expected a dict")
                records[key] = cache.put(key, todo[key], settings, result)
            except Exception as exc:  # keep going: the other results are still worth caching
                failures.append((todo[key], exc))
            bar.update()

        if scheduler is None and max_workers == 0:
            for key, design in todo.items():
                store(key, lambda design=design: evaluate(design, settings))
        elif scheduler is None:
            _run_pool(todo, evaluate, settings, max_workers, store)
        else:
            _run_dask(todo, evaluate, settings, scheduler, store)
    finally:
        bar.close()
    return failures


def _run_pool(todo: dict, evaluate, settings: dict, max_workers: int | None, store) -> None:
    workers = 1 if max_workers is None else int(max_workers)
    if workers < 1:
        raise ValueError(f"max_workers = {max_workers!r}: must be >= 1")
    pool = ProcessPoolExecutor(min(workers, len(todo)), mp_context=multiprocessing.get_context("spawn"))
    pending = {pool.submit(evaluate, design, settings): key for key, design in todo.items()}
    try:
        while pending:
            done, _ = wait(pending, return_when=FIRST_COMPLETED)
            for fut in done:
                store(pending.pop(fut), fut.result)
    except BaseException:
        # interrupted (Ctrl-C, or a BaseException out of a worker): drop what has not
        # started, let the running ones finish, and keep whatever finished cleanly
        pool.shutdown(wait=True, cancel_futures=True)
        for fut, key in pending.items():
            if fut.done() and not fut.cancelled() and fut.exception() is None:
                store(key, fut.result)
        raise
    pool.shutdown(wait=True)


def _dask_completed(scheduler, calls: dict):
    """Yield ``(tag, future.result)`` for each call ``{tag: (fn, *args)}`` as the cluster finishes it.

    The calls not yet finished when the caller stops are cancelled.
    """
    from distributed import as_completed

    client, owned = _client_for(scheduler)
    try:
        # pure=False: a failed attempt under the same task key must not be reused on retry
        pending = {client.submit(*call, pure=False): tag for tag, call in calls.items()}
        try:
            for fut in as_completed(list(pending)):
                yield pending.pop(fut), fut.result
        finally:
            if pending:
                client.cancel(list(pending))
    finally:
        if owned:
            client.close()


def _run_dask(todo: dict, evaluate, settings: dict, scheduler, store) -> None:
    calls = {key: (evaluate, design, settings) for key, design in todo.items()}
    for key, outcome in _dask_completed(scheduler, calls):
        store(key, outcome)


def _run_group(designs: list, evaluate, settings: dict, cache_dir) -> list[dict]:
    """One geometry's designs in this process (its model meshed once): a pool task."""
    return run_designs(designs, evaluate, settings, cache_dir, max_workers=0, progress=False)


def run_geometry_designs(
    items: Sequence[tuple[Mapping, Mapping]],
    evaluate: Callable[[dict, dict], Mapping],
    settings: Mapping,
    cache_dir: str | os.PathLike,
    max_workers: int | None = None,
    progress: bool = True,
    scheduler=None,
) -> list[dict]:
    """:func:`run_designs` for designs that differ in geometry too: ``(moduli, dimensions)`` pairs.

    Each pair's dimensions (m) override ``settings["geometry"]``, so each design is cached under
    the settings of its own geometry. Designs are grouped by geometry, one group per task, so a
    geometry is meshed and assembled once for all its moduli. ``max_workers`` worker processes
    (spawned; default 1; 0: this process). Records come back in input order.

    ``scheduler`` (an address or a ``distributed.Client``, as for :func:`run_designs`) sends the
    groups to a Dask cluster instead; ``max_workers`` is then ignored. A worker caches each design
    as it finishes, in ``cache_dir`` as that worker sees it, so a group whose worker dies is redone
    by another worker from its first uncached design when the directory is shared (one machine, or
    a network file system). This process also caches every record it receives.
    """
    settings = keyed_settings(evaluate, settings)
    groups: dict[str, tuple[dict, list[int]]] = {}
    for i, (_, dims) in enumerate(items):
        s = dict(settings, geometry={**settings.get("geometry", {}), **_canonical(dims, "geometry")})
        groups.setdefault(_dumps(s), (s, []))[1].append(i)
    cache = ResultCache(cache_dir)
    out: list[dict | None] = [None] * len(items)
    todo = []
    for s, idx in groups.values():
        designs = [_canonical_design(items[i][0]) for i in idx]
        recs = [cache.get(design_key(d, s)) for d in designs]
        for i, r in zip(idx, recs, strict=True):
            out[i] = r
        if any(r is None for r in recs):
            todo.append((s, idx, designs))
    bar = tqdm(total=len(todo), desc="FE geometries", unit="geometry", disable=None if progress else True)
    try:
        if scheduler is not None:
            # the scheduler reruns a lost worker's group elsewhere, from its first uncached design
            where = str(cache.directory.absolute())
            calls = {j: (_run_group, designs, evaluate, s, where) for j, (s, _, designs) in enumerate(todo)}
            for j, outcome in _dask_completed(scheduler, calls):
                for i, r in zip(todo[j][1], outcome(), strict=True):
                    # a worker on another machine cached it in its own file system: keep a copy here
                    out[i] = cache.get(r["key"]) or cache.put(
                        r["key"], r["design"], r["settings"], r["result"]
                    )
                bar.update()
        elif max_workers == 0:
            for s, idx, designs in todo:
                for i, r in zip(idx, _run_group(designs, evaluate, s, cache_dir), strict=True):
                    out[i] = r
                bar.update()
        else:
            workers = 1 if max_workers is None else int(max_workers)
            ctx = multiprocessing.get_context("spawn")
            with ProcessPoolExecutor(max(1, min(workers, len(todo) or 1)), mp_context=ctx) as pool:
                futs = {
                    pool.submit(_run_group, designs, evaluate, s, cache_dir): idx for s, idx, designs in todo
                }
                for fut in futs:
                    for i, r in zip(futs[fut], fut.result(), strict=True):
                        out[i] = r
                    bar.update()
    finally:
        bar.close()
    return out  # type: ignore[return-value]
