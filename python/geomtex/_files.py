"""Files geomtex writes from Python (pictures): atomic, with the user's umask, in the format the
extension names. The .gtex writer in Rust (src/gtex/file.rs) follows the same rules."""

from __future__ import annotations

import os
import secrets
from typing import Any, BinaryIO, Callable

from ._errors import FileError, ParameterError


def write_atomically(path: Any, write: Callable[[BinaryIO], None]) -> None:
    """Calls ``write(f)`` on a temporary file beside `path`, then renames it over `path`; on any
    error the temporary file is removed, so no half file is ever left. The file gets
    ``0o666 & ~umask`` like any file the user creates (mkstemp's 0600 would survive the rename)."""
    target = os.fspath(path)
    folder = os.path.dirname(os.path.abspath(target))
    tmp = os.path.join(folder, f".{os.path.basename(target)}.{secrets.token_hex(4)}.tmp")
    try:
        fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666)
    except OSError as e:
        raise FileError(f"cannot create a temporary file to write {target}: {e.strerror}") from None
    try:
        with os.fdopen(fd, "wb") as f:
            write(f)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, target)
    except BaseException as e:
        os.unlink(tmp)
        if isinstance(e, OSError) and not isinstance(e, FileError):
            raise FileError(f"cannot write {target}: {e.strerror or e}") from None
        raise


def image_format(path: Any) -> str:
    """Pillow's format name for `path`'s extension (PNG for .png, JPEG for .jpg/.jpeg, ...);
    ParameterError for an extension no Pillow writer knows."""
    from PIL import Image

    target = os.fspath(path)
    ext = os.path.splitext(target)[1].lower()
    fmt = Image.registered_extensions().get(ext)
    if fmt is None or fmt not in Image.SAVE:
        raise ParameterError(
            f"path {target!r}: extension {ext or '(none)'!r} names no image format Pillow can write; "
            "use .png or .jpg")
    return fmt


def save_image(image: Any, path: Any) -> None:
    """Writes a PIL image in the format `path`'s extension names (checked before anything is
    written); formats without alpha (JPEG) get the image flattened to RGB."""
    if not isinstance(path, (str, os.PathLike)):
        raise ParameterError(f"path must be a str or os.PathLike, got {path!r}")
    fmt = image_format(path)
    if fmt in ("JPEG", "BMP", "PPM") and image.mode not in ("RGB", "L"):
        image = image.convert("RGB")
    write_atomically(path, lambda f: image.save(f, format=fmt))
