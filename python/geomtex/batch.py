"""Batch jobs on Dask distributed: many meshes converted, many views rendered.

>>> from geomtex import batch
>>> rows = batch.convert_many(["a.obj", "b.ply"], "out/", max_resolution=128)
>>> batch.render_views(["out/a-1f3c.gtex"], cameras, "views.zarr", width=256, height=256)

What runs where:

- The calling process (the *client*) lists the inputs, reads and writes the manifest, creates the
  Zarr arrays, and submits one task per input (conversion) or per block of views (rendering). It
  never converts or renders itself.
- Each Dask *worker* process converts a mesh or renders views. Heavy calls release the GIL and
  use every core through rayon, so a worker with several threads runs several tasks at once;
  each worker process keeps one `Renderer` per image size for its whole life (the GPU device
  and uploads are made once, not per task).
- Files: a worker writes its .gtex atomically (temporary file, then rename) and its views
  straight into their own Zarr chunks; only small rows (status, stats, seconds) travel back.
  Inputs given as paths travel as paths; in-memory meshes and sets are pickled (a set as its
  .gtex bytes) and scattered once.

The manifest (``manifest.json`` in the output folder) holds one row per input: its key, status
(``"done"`` or ``"failed"``), output file, stats, seconds and error message. While a job runs, each
result is appended as one line to ``manifest.journal`` (flushed at once, synced at least every
second), so recording a result costs the same whatever the job's size; the journal is folded into
``manifest.json`` (written atomically) when the job ends. A job killed at any point can be run
again: `read_manifest` replays the journal over the manifest, inputs already done (their file
present with the recorded size) are skipped, and a finished job does no work.

Needs the optional dependencies ``pip install geomtex[distributed]`` (dask[distributed], zarr).
"""

from __future__ import annotations

import contextlib
import hashlib
import importlib.util
import json
import os
import tempfile
import time
import traceback
import uuid
from collections.abc import Iterable, Iterator, Sequence
from typing import Any

import numpy as np

from . import _check, _optional, _progress
from . import convert as _convert
from ._bridge import keyword_parameters, spelled_out
from ._camera import Camera
from ._errors import CancelledError, FileError, GeomtexError, ParameterError
from ._render import RenderOptions

__all__ = ["convert_many", "read_manifest", "render_views"]

MANIFEST = "manifest.json"
JOURNAL = "manifest.journal"
_MANIFEST_VERSION = 1


def _dask() -> Any:
    return _optional.need("dask.distributed", "geomtex.batch")


@contextlib.contextmanager
def _client(client: Any, n_workers: int | None) -> Iterator[Any]:
    """The Dask client to use: the one given, one connected to an address, or a LocalCluster of
    worker processes (one thread each) started for this call and closed after it."""
    distributed = _dask()
    if isinstance(client, distributed.Client):
        yield client
    elif isinstance(client, str):
        with distributed.Client(client) as connected:
            yield connected
    elif client is None:
        # A dashboard on a free port where bokeh is installed; the bar shows its link.
        dashboard = ":0" if importlib.util.find_spec("bokeh") else None
        with distributed.LocalCluster(n_workers=n_workers or min(os.cpu_count() or 1, 4), threads_per_worker=1,
                                      processes=True, dashboard_address=dashboard) as cluster, \
                distributed.Client(cluster) as local:
            yield local
    else:
        raise ParameterError(f"client must be a dask.distributed.Client, an address or None, got {client!r}")


# ---------------------------------------------------------------------------------------------
# Arguments, checked before anything is written or any worker starts


def _check_job(client: Any, n_workers: Any, progress: Any) -> None:
    if client is not None and not isinstance(client, str) and not isinstance(client, _dask().Client):
        raise ParameterError(f"client must be a dask.distributed.Client, an address or None, got {client!r}")
    if n_workers is not None:
        _check.integer("n_workers", n_workers, 1, 1024)
    _check.flag("progress", progress)


def _listed(name: str, items: Any, what: str) -> list[Any]:
    """`items` as a list: a list, tuple or other iterable, not one str or path."""
    if isinstance(items, (str, bytes, os.PathLike)) or not isinstance(items, Iterable):
        raise _check.fail(name, f"a list of {what} (one path: [path])", items)
    return list(items)


def _cancel(stage: str, fraction: float) -> bool:
    return False


def _check_convert_options(options: dict[str, Any]) -> dict[str, Any]:
    """`geomtex.convert`'s keywords as plain JSON values (numpy scalars become Python numbers),
    checked by the conversion's own checks on one triangle, cancelled before any work."""
    import inspect

    import geomtex as gt

    known = [name for name in inspect.signature(gt.convert).parameters if name not in ("mesh", "progress")]
    for name in options:
        if name not in known:
            raise ParameterError(f"unknown convert option {name!r}; geomtex.convert takes {', '.join(known)}")
    plain = {name: value.item() if isinstance(value, np.generic) else value for name, value in options.items()}
    try:
        gt.convert(gt.Mesh([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]], [[0, 1, 2]]), progress=_cancel,
                   **plain)
    except CancelledError:  # every option was read: the conversion stopped at its first stage
        pass
    return plain


def _check_objects(objects: Any) -> list[Any]:
    """render_views' objects: each a path to a file that exists, or anything a Scene takes."""
    from ._kinds import renderable

    objs = _listed("objects", objects, "sets, meshes, scenes or paths")
    for i, obj in enumerate(objs):
        if isinstance(obj, (str, os.PathLike)):
            p = _check.path(f"objects[{i}]", obj)
            if not os.path.isfile(p):
                raise FileError(f"objects[{i}]: no such file: {p}")
        else:
            renderable(obj)  # a MeshError for what is no mesh
    return objs


# ---------------------------------------------------------------------------------------------
# Inputs and their keys


def _input_key(source: Any, index: int) -> tuple[str, str, dict[str, Any]]:
    """(key, description, fingerprint) of one input. A path's key comes from its absolute path
    and its fingerprint from its size and mtime (a changed file is converted again); an
    in-memory mesh's key is a hash of its arrays, so the same mesh always maps to the same file."""
    if isinstance(source, (str, os.PathLike)):
        path = os.path.abspath(os.fspath(source))
        try:
            st = os.stat(path)
        except OSError as e:
            raise FileError(f"input {index}: cannot read {path}: {e.strerror}") from None
        stem = os.path.splitext(os.path.basename(path))[0]
        digest = hashlib.sha1(path.encode()).hexdigest()[:10]
        return f"{stem}-{digest}", path, {"size": st.st_size, "mtime_ns": st.st_mtime_ns}
    from ._mesh import as_mesh

    mesh = as_mesh(source)
    h = hashlib.sha1()
    for a in (mesh.vertices, mesh.faces, mesh.vertex_colors, mesh.face_colors, mesh.uv, mesh.texture):
        h.update(b"-" if a is None else np.ascontiguousarray(a).tobytes())
    digest = h.hexdigest()[:16]
    return f"mesh-{digest}", f"<Mesh {mesh.n_vertices} vertices, {mesh.n_faces} faces>", {"sha1": digest}


def _scalar_stats(stats: dict[str, Any]) -> dict[str, Any]:
    """The stats a manifest row keeps: numbers and strings (per-patch arrays stay in the file)."""
    return {k: (v.item() if isinstance(v, np.generic) else v) for k, v in stats.items()
            if v is None or isinstance(v, (bool, int, float, str, np.generic))}


# ---------------------------------------------------------------------------------------------
# The manifest


def _write_json_atomically(path: str, data: Any) -> None:
    folder = os.path.dirname(path) or "."
    fd, tmp = tempfile.mkstemp(dir=folder, prefix=".manifest-", suffix=".tmp")
    try:
        with os.fdopen(fd, "w") as f:
            json.dump(data, f, indent=1, allow_nan=True)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise


def read_manifest(out_dir: str | os.PathLike[str]) -> dict[str, Any]:
    """The manifest of a `convert_many` job: ``{"version", "options", "rows"}``, rows keyed by
    input key, with the journal of a job that did not finish replayed over it. An empty one where
    the folder holds none.

    Every row is checked as it is read (a key, a status of "done" or "failed", an output file
    name beside the manifest, a byte count for a done row, ...): a damaged manifest or journal
    raises FormatError naming the file and the line, rather than resuming a job from rows that
    cannot be right. The one exception is a journal's last line without its newline, which a
    crash mid-write leaves torn: it is skipped, and that input converted again."""
    from ._errors import FileError

    folder = _check.path("out_dir", out_dir)
    path = os.path.join(folder, MANIFEST)
    manifest: dict[str, Any] = {"version": _MANIFEST_VERSION, "options": None, "rows": {}}
    try:
        if os.path.exists(path):
            with open(path, "rb") as f:
                manifest = _parse_manifest(path, f.read())
        _replay_journal(os.path.join(folder, JOURNAL), manifest["rows"])
    except OSError as e:
        raise FileError(f"cannot read the batch manifest in {folder}: {e}") from None
    return manifest


def _format_error(path: str, line: int | None, message: str) -> Exception:
    from ._errors import FormatError

    return FormatError(f"{path}{'' if line is None else f' line {line}'}: {message}")


def _parse_manifest(path: str, data: bytes) -> dict[str, Any]:
    """manifest.json's content, checked: FormatError naming the file and line where it is wrong."""
    try:
        text = data.decode("utf-8")
        manifest = json.loads(text)
    except UnicodeDecodeError as e:
        raise _format_error(path, data.count(b"\n", 0, e.start) + 1, "not UTF-8 text") from None
    except json.JSONDecodeError as e:
        raise _format_error(path, e.lineno, f"not JSON ({e.msg}, column {e.colno})") from None
    except RecursionError:
        raise _format_error(path, None, "not a manifest (nested too deeply)") from None
    if not isinstance(manifest, dict) or manifest.get("version") != _MANIFEST_VERSION \
            or not isinstance(manifest.get("rows"), dict):
        raise _format_error(path, None, f"not a geomtex batch manifest of version {_MANIFEST_VERSION}")
    if manifest.get("options") is not None and not isinstance(manifest["options"], dict):
        raise _format_error(path, None, f"options must be an object, got {manifest['options']!r:.60}")
    for key, row in manifest["rows"].items():
        problem = _row_problem(row, key)
        if problem:
            # The manifest is written one field a line: the row's line is where its key is.
            at = text.find(json.dumps(key) + ":")
            raise _format_error(path, text.count("\n", 0, at) + 1 if at >= 0 else None,
                                f"row {key!r:.60}: {problem}")
    return manifest


def _is_number(value: Any) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def _row_problem(row: Any, key: str | None = None) -> str | None:
    """What makes `row` no manifest row (as `_run_conversions` writes them), or None."""
    if not isinstance(row, dict):
        return f"a row must be an object, got {type(row).__name__}"
    if not isinstance(row.get("key"), str) or not row["key"] or (key is not None and row["key"] != key):
        return f"its key {row.get('key')!r:.60} is not a non-empty string" + (f" equal to {key!r:.60}" if key else "")
    status, output = row.get("status"), row.get("output")
    if status not in ("done", "failed"):
        return f"status {status!r:.60}; expected 'done' or 'failed'"
    if not isinstance(output, str) or not output.endswith(".gtex") or os.path.basename(output) != output \
            or output.startswith(".") or "\\" in output:
        return f"output {output!r:.60} is not a .gtex file name beside the manifest"
    if not isinstance(row.get("fingerprint"), dict):
        return "its fingerprint is not an object"
    nbytes = row.get("bytes")
    if status == "done" and (not isinstance(nbytes, int) or isinstance(nbytes, bool) or nbytes < 0):
        return f"a done row's bytes {nbytes!r:.60} is not a byte count"
    if status == "failed" and not isinstance(row.get("error"), str):
        return "a failed row has no error message"
    for name in ("stats", "stage_seconds"):
        if row.get(name) is not None and not isinstance(row[name], dict):
            return f"its {name} is not an object"
    if row.get("seconds") is not None and not _is_number(row["seconds"]):
        return f"its seconds {row['seconds']!r:.60} is not a number"
    return None


def _replay_journal(path: str, rows: dict[str, Any]) -> None:
    """Applies the rows a running (or killed) job appended after the manifest was last written.

    Each line must be one whole manifest row (FormatError naming the journal and the line
    otherwise), except the last line when it lacks its newline: a crash mid-write tears it, so
    if it is not valid JSON it is skipped, silently by design (that input has no result on
    record and is simply converted again)."""
    if not os.path.exists(path):
        return
    with open(path, "rb") as f:
        lines = f.read().split(b"\n")
    for number, line in enumerate(lines, 1):
        if not line.strip():
            continue
        try:
            row = json.loads(line)
        except (ValueError, RecursionError):  # not JSON, not UTF-8, or nested past Python's stack
            if number == len(lines):  # the last, unterminated line: torn by a crash
                continue
            raise _format_error(path, number, "not a manifest row (not JSON)") from None
        problem = _row_problem(row)
        if problem:
            raise _format_error(path, number, problem)
        rows[row["key"]] = row


def _already_done(row: dict[str, Any] | None, fingerprint: dict[str, Any], out_dir: str) -> bool:
    if not row or row.get("status") != "done" or row.get("fingerprint") != fingerprint:
        return False
    path = os.path.join(out_dir, row["output"])
    return os.path.exists(path) and os.path.getsize(path) == row.get("bytes")


def _wanted(row: dict[str, Any] | None, fingerprint: dict[str, Any], out_dir: str, retry_failed: bool) -> bool:
    """Whether an input needs converting: not done, and not failed before unless retried."""
    if _already_done(row, fingerprint, out_dir):
        return False
    failed_before = row is not None and row.get("status") == "failed" and row.get("fingerprint") == fingerprint
    return retry_failed or not failed_before


# ---------------------------------------------------------------------------------------------
# Conversion


def _convert_one(source: Any, out_path: str, options: dict[str, Any]) -> dict[str, Any]:
    """Runs on a worker: converts one input and writes its .gtex atomically. Never raises for a
    bad input: the row says what went wrong, so the scheduler does not retry a certain failure."""
    import geomtex as gt

    start = time.perf_counter()
    try:
        gts = gt.convert(source, **options)
        gts.save(out_path)
        return {"status": "done", "seconds": time.perf_counter() - start, "bytes": os.path.getsize(out_path),
                "stats": _scalar_stats(gts.stats), "stage_seconds": dict(gts.stats["seconds"]), "error": None,
                "worker_pid": os.getpid()}
    except GeomtexError as e:
        error = f"{type(e).__name__}: {e}"
    except Exception as e:  # any other failure is recorded too, with where it came from
        error = f"{type(e).__name__}: {e}\n{traceback.format_exc(limit=3)}"
    return {"status": "failed", "seconds": time.perf_counter() - start, "bytes": None, "stats": None,
            "error": error, "worker_pid": os.getpid()}


@spelled_out(*keyword_parameters(_convert, drop=("progress",)))
def convert_many(
    inputs: Iterable[Any],
    out_dir: str | os.PathLike[str],
    *,
    client: Any = None,
    n_workers: int | None = None,
    retry_failed: bool = False,
    progress: bool = True,
    **convert_options: Any,
) -> list[dict[str, Any]]:
    """Converts every input to ``out_dir/<key>.gtex`` on Dask workers.

    A worker that dies mid-task has its task run again elsewhere (Dask's ``allowed-failures``);
    an input whose tasks keep killing workers is recorded as failed. Inputs already done in an
    earlier run with the same options are skipped.

    Parameters
    ----------
    inputs : iterable
        Mesh paths, Mesh or trimesh objects.
    out_dir : str or os.PathLike
        The output folder, made if missing; it holds the manifest.
    client : dask.distributed.Client or str, optional
        A client, a scheduler address, or None for a LocalCluster of `n_workers` processes
        (default: the cores, at most 4) for this call.
    n_workers : int, optional
        Workers of the LocalCluster made without `client`.
    retry_failed : bool, default False
        Convert inputs that failed in an earlier run again (they are skipped by default: a bad
        mesh fails the same way twice).
    progress : bool, default True
        A tqdm bar over the inputs (the client's dashboard, where it has one, shows the tasks
        too).
    **convert_options
        As for :func:`geomtex.convert` (its ``progress`` aside: ``progress`` is the job's).

    Returns
    -------
    list of dict
        The manifest rows of these inputs, in input order; each input gets exactly one row,
        ``status`` "done" or "failed" (with ``error``).

    Raises
    ------
    ParameterError
        A bad option (checked before any worker starts), an input named twice, or a folder
        holding a job converted with other options.
    FileError
        The output folder cannot be made.
    """
    out = _check.path("out_dir", out_dir)
    _check_job(client, n_workers, progress)
    _check.flag("retry_failed", retry_failed)
    sources = _listed("inputs", inputs, "mesh paths or meshes")
    options = dict(sorted(_check_convert_options(convert_options).items()))
    keyed = [(*_input_key(source, i), source) for i, source in enumerate(sources)]
    if len({k for k, *_ in keyed}) != len(keyed):
        raise ParameterError("inputs name the same file or mesh twice")
    try:
        os.makedirs(out, exist_ok=True)
    except OSError as e:
        raise FileError(f"cannot make the output folder {out}: {e.strerror or e}") from None
    manifest = read_manifest(out)
    if manifest["rows"] and manifest["options"] != json.loads(json.dumps(options)):
        raise ParameterError(f"{out} holds a job converted with options {manifest['options']}, not {options}; "
                             "use another folder")
    manifest["options"] = options
    rows: dict[str, Any] = manifest["rows"]
    todo = [(key, desc, fp, src) for key, desc, fp, src in keyed if _wanted(rows.get(key), fp, out, retry_failed)]
    if todo:
        _run_conversions(todo, out, options, manifest, client, n_workers, progress)
    return [rows[key] for key, *_ in keyed]


def _run_conversions(todo: list[tuple[str, str, dict[str, Any], Any]], out: str, options: dict[str, Any],
                     manifest: dict[str, Any], client: Any, n_workers: int | None, progress: bool) -> None:
    distributed = _dask()
    _write_json_atomically(os.path.join(out, MANIFEST), manifest)  # the options, and any replayed rows
    # Task keys name the input and this run: a key the scheduler still holds from an earlier run
    # on the same client (released lazily) would hand back that run's result without converting.
    run = uuid.uuid4().hex[:8]
    with _client(client, n_workers) as c, _Journal(os.path.join(out, JOURNAL)) as journal:
        futures = {}
        for key, desc, fp, source in todo:
            shipped = os.path.abspath(os.fspath(source)) if isinstance(source, (str, os.PathLike)) else source
            future = c.submit(_convert_one, shipped, os.path.join(out, f"{key}.gtex"), options,
                              key=f"geomtex-convert-{key}-{run}", pure=False)
            futures[future] = (key, desc, fp)
        bar = _bar(len(futures), "converting", progress, c)
        for future in distributed.as_completed(futures):
            key, desc, fp = futures[future]
            try:
                row = future.result()
            except Exception as e:  # the task never returned: its workers died (KilledWorker)
                row = {"status": "failed", "seconds": None, "bytes": None, "stats": None,
                       "error": f"{type(e).__name__}: {e}", "worker_pid": None}
            manifest["rows"][key] = {"key": key, "input": desc, "output": f"{key}.gtex", "fingerprint": fp, **row}
            journal.append(manifest["rows"][key])
            if bar is not None:
                bar.update(1)
        if bar is not None:
            bar.close()
    # Every result is in the journal: fold it into the manifest, then drop it.
    _write_json_atomically(os.path.join(out, MANIFEST), manifest)
    with contextlib.suppress(FileNotFoundError):
        os.unlink(os.path.join(out, JOURNAL))


class _Journal:
    """manifest.journal: one JSON row a line, appended as results arrive. Each line is written and
    flushed whole; the file is synced at most once a second (a machine crash loses at most that
    second of rows, which are then converted again), so recording a result never rewrites the
    manifest (at 100k inputs that is ~100 MB of JSON)."""

    def __init__(self, path: str) -> None:
        self.path = path
        self.file: Any = None
        self.last_sync = 0.0

    def __enter__(self) -> _Journal:
        # The manifest just written holds every row replayed from an earlier journal (a torn
        # last line included, as not done), so the journal starts empty.
        self.file = open(self.path, "wb")
        return self

    def append(self, row: dict[str, Any]) -> None:
        self.file.write(json.dumps(row, allow_nan=True).encode() + b"\n")
        self.file.flush()
        if time.monotonic() - self.last_sync > 1.0:
            os.fsync(self.file.fileno())
            self.last_sync = time.monotonic()

    def __exit__(self, *exc: object) -> None:
        os.fsync(self.file.fileno())
        self.file.close()


def _bar(total: int, what: str, progress: bool, client: Any) -> Any:
    if not progress:
        return None
    bar = _progress.bar(total, f"geomtex {what}", "task")
    services: dict[str, Any] = client.scheduler_info().get("services", {})
    link = client.dashboard_link if "dashboard" in services else None
    if link:
        bar.set_postfix_str(f"dashboard {link}", refresh=False)
    return bar


# ---------------------------------------------------------------------------------------------
# Rendering

_OUTPUTS = {"depth": ("f4", (), np.inf), "normal": ("f4", (3,), 0.0), "color": ("u1", (4,), 0),
            "albedo": ("u1", (4,), 0), "patch_id": ("i4", (), -1)}


def _array(group: Any, name: str) -> Any:
    """One array of a zarr group (typed as Any: zarr's item type is a union of Array and Group)."""
    zarr = _optional.need("zarr", "geomtex.batch")

    array = group[name]
    if not isinstance(array, zarr.Array):
        raise ParameterError(f"the store's {name!r} is a group, not an array; use another store")
    return array


def _render_block(obj: Any, set_index: int, views: list[tuple[int, Any]], store: str, width: int, height: int,
                  outputs: Sequence[str], options: dict[str, Any]) -> dict[str, Any]:
    """Runs on a worker: renders the views of one object and writes each into its own chunks."""
    import geomtex as gt

    zarr = _optional.need("zarr", "geomtex.batch")

    from ._render import shared_renderer

    start = time.perf_counter()
    if isinstance(obj, (str, os.PathLike)):
        obj = gt.load(obj) if os.fspath(obj).endswith(".gtex") else gt.load_mesh(obj)
    group = zarr.open_group(store, mode="r+")
    renderer = shared_renderer(width, height)  # one per worker process, kept for its life
    arrays = {name: _array(group, name) for name in outputs}
    done = _array(group, "done")
    for view, camera in views:
        # Only the outputs stored are read back from the adapter.
        frame = renderer.render(obj, camera, **options, outputs=tuple(outputs))
        for name in outputs:
            arrays[name][set_index, view] = getattr(frame, name)
        done[set_index, view] = True  # written last: a view marked done has all its chunks
    return {"seconds": time.perf_counter() - start, "views": len(views), "worker_pid": os.getpid()}


@spelled_out(*keyword_parameters(RenderOptions, drop=("outputs",)))
def render_views(
    objects: Sequence[Any],
    cameras: Sequence[Camera] | Sequence[Sequence[Camera]],
    out: str | os.PathLike[str],
    *,
    width: int,
    height: int,
    outputs: Sequence[str] = ("depth", "normal", "color", "patch_id"),
    client: Any = None,
    n_workers: int | None = None,
    views_per_task: int = 8,
    progress: bool = True,
    **render_options: Any,
) -> Any:
    """Renders every object (sets, meshes, scenes, or .gtex / mesh paths) from every camera into a
    Zarr store at `out` and returns it opened as a ``zarr.Group``.

    Views are rendered in tasks of `views_per_task` views of one object; each worker keeps one
    Renderer for its life. Depth is bit-identical to `Renderer.render` in this process.

    Parameters
    ----------
    objects : sequence
        Sets, meshes, scenes, or .gtex / mesh paths.
    cameras : sequence of Camera, or one sequence per object
        One list for every object, or one list per object (all of the same length).
    out : str or os.PathLike
        The Zarr store.
    width, height : int
        The image size.
    outputs : sequence of str, default ("depth", "normal", "color", "patch_id")
        Any of "depth", "normal", "color", "albedo", "patch_id"; each becomes an array of shape
        (objects, views, height, width[, channels]) chunked one view per chunk, with the
        frame's dtype and miss value. ``done`` (objects, views) marks the views written, so a
        rerun into the same store renders only the views not yet done.
    client, n_workers, progress
        As for `convert_many`.
    views_per_task : int, default 8
        Views of one object per Dask task.
    **render_options
        As for `Renderer.render` (quality, lod, background, light, ...), checked before any
        worker starts.

    Returns
    -------
    zarr.Group
        The store, opened.
    """
    from ._render import check_render_options

    zarr = _optional.need("zarr", "geomtex.batch.render_views")

    width, height = _check.image_size(width, height)
    names = _listed("outputs", outputs, f"output names, some of {sorted(_OUTPUTS)}")
    unknown = [name for name in names if not isinstance(name, str) or name not in _OUTPUTS]
    if unknown or not names:
        raise ParameterError(f"outputs must be some of {sorted(_OUTPUTS)}, got {names}")
    outputs = names
    views_per_task = _check.integer("views_per_task", views_per_task, 1, 1 << 20)
    _check_job(client, n_workers, progress)
    check_render_options(render_options)
    out = _check.path("out", out)
    objs = _check_objects(objects)
    per_object = _cameras_per_object(cameras, len(objs))
    n_views = len(per_object[0]) if per_object else 0
    group = zarr.open_group(os.fspath(out), mode="a")
    shape = (len(objs), n_views, height, width)
    if "done" in group and _array(group, "done").shape != shape[:2]:
        raise ParameterError(f"{out} holds views of another shape {_array(group, 'done').shape}; "
                             "use another store")
    for name in outputs:
        dtype, channels, fill = _OUTPUTS[name]
        if name not in group:
            group.create_array(name, shape=shape + channels, chunks=(1, 1, height, width) + channels,
                               dtype=dtype, fill_value=fill)
    if "done" not in group:
        # One chunk per view here too: workers write their views' flags at once, and a shared
        # chunk would be read, changed and written back by both (a lost update).
        group.create_array("done", shape=shape[:2], chunks=(1, 1), dtype=bool, fill_value=False)
    group.attrs.update({"width": width, "height": height, "outputs": list(outputs)})
    done = _array(group, "done")[...]
    blocks = [(i, [(v, per_object[i][v]) for v in range(start, min(start + views_per_task, n_views))
                   if not done[i, v]])
              for i in range(len(objs)) for start in range(0, n_views, max(1, views_per_task))]
    blocks = [(i, views) for i, views in blocks if views]
    if blocks:
        _run_renders(objs, blocks, os.fspath(out), width, height, list(outputs), render_options,
                     client, n_workers, progress)
    return zarr.open_group(os.fspath(out), mode="r")


def _cameras_per_object(cameras: Any, n_objects: int) -> list[list[Camera]]:
    wanted = "a list of Cameras, or one equally long list of Cameras per object"
    cams = _listed("cameras", cameras, wanted[2:])
    if all(isinstance(c, Camera) for c in cams):
        return [cams] * n_objects
    if not all(isinstance(c, Iterable) and not isinstance(c, (str, bytes)) for c in cams):
        raise _check.fail("cameras", wanted, cameras)
    per = [list(c) for c in cams]
    if len(per) != n_objects or len({len(p) for p in per}) > 1 \
            or not all(isinstance(c, Camera) for p in per for c in p):
        raise _check.fail("cameras", wanted, cameras)
    return per


def _run_renders(objs: list[Any], blocks: list[tuple[int, list[tuple[int, Any]]]], store: str, width: int,
                 height: int, outputs: list[str], options: dict[str, Any], client: Any,
                 n_workers: int | None, progress: bool) -> None:
    distributed = _dask()
    with _client(client, n_workers) as c:
        # Paths travel as paths; an object in memory is scattered once and shared by its tasks.
        shipped: dict[int, Any] = {}
        for i in {i for i, _ in blocks}:
            obj = objs[i]
            shipped[i] = os.path.abspath(os.fspath(obj)) if isinstance(obj, (str, os.PathLike)) \
                else c.scatter(obj, hash=False)
        futures = [c.submit(_render_block, shipped[i], i, views, store, width, height, outputs, options,
                            pure=False) for i, views in blocks]
        bar = _bar(sum(len(v) for _, v in blocks), "rendering", progress, c)
        for future in distributed.as_completed(futures):
            result = future.result()  # a render error is the caller's to see, as in Renderer.render
            if bar is not None:
                bar.update(result["views"])
        if bar is not None:
            bar.close()
