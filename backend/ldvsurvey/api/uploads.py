"""Reading an upload safely: one bundle ``.zip`` or the bundle's separate files.

A zip is judged by its central directory before a single byte is inflated: member names, the
number of members, the total declared size and the compression ratio. Only the bundle's own files
are then inflated, streamed to a temporary folder under a running byte budget (headers can lie)
and hashed on the way; they are parsed from there and linked into the blob folder when stored, never
held in memory whole. Anything else in the archive is named in a warning, never inflated.
"""

from __future__ import annotations

import posixpath
import zipfile
from pathlib import Path
from typing import BinaryIO

from fastapi import UploadFile

from ldvsurvey.errors import BundleError, TooLargeError
from ldvsurvey.io.drivelog import KNOWN_FILES, ZIP_READ_ERRORS, BundleFiles, refuse_encrypted

CHUNK = 1 << 20
#: members smaller than this are not judged by their own ratio (tiny files compress oddly)
RATIO_FLOOR_BYTES = 64 * 1024


def _safe_name(fn: str, archive: str) -> None:
    parts = fn.replace("\\", "/").split("/")
    if fn.startswith(("/", "\\")) or (len(fn) > 1 and fn[1] == ":") or ".." in parts or "\x00" in fn or len(fn) > 255:
        raise BundleError(f"unsafe path in archive: '{fn[:200]}'", file=archive, field=fn[:200])


def plan_zip(
    zf: zipfile.ZipFile, archive_bytes: int, *, max_unzipped: int, max_ratio: float, max_members: int, archive: str
) -> tuple[dict[str, zipfile.ZipInfo], list[str]]:
    """Judge an archive by its directory only.

    Returns
    -------
    (inflate, ignored) : the bundle members to inflate (bundle name -> entry) and the names of
        other files, which are not inflated.
    """
    infos = zf.infolist()
    if len(infos) > max_members:
        raise TooLargeError(f"archive has {len(infos)} entries; a bundle has at most {max_members}", file=archive)
    files = []
    for info in infos:
        _safe_name(info.filename, archive)
        fn = info.filename
        if info.is_dir() or fn.startswith("__MACOSX/") or posixpath.basename(fn).startswith("._"):
            continue
        files.append(info)
    if not files:
        raise BundleError("archive holds no files", file=archive)
    for i in files:
        refuse_encrypted(i, archive)
    declared = sum(i.file_size for i in files)
    if declared > max_unzipped:
        raise TooLargeError(
            f"archive declares {declared} bytes unpacked, more than the limit of {max_unzipped}", file=archive
        )
    if declared > CHUNK and declared > max_ratio * max(archive_bytes, 1):
        raise TooLargeError(
            f"archive unpacks {declared / max(archive_bytes, 1):.0f}:1 (limit {max_ratio:.0f}:1): "
            "refusing a possible zip bomb",
            file=archive,
        )
    for i in files:
        if i.file_size > RATIO_FLOOR_BYTES and i.file_size > max_ratio * max(i.compress_size, 1):
            raise TooLargeError(
                f"member '{i.filename}' compresses {i.file_size / max(i.compress_size, 1):.0f}:1 "
                f"(limit {max_ratio:.0f}:1): refusing a possible zip bomb",
                file=archive,
                field=i.filename,
            )
    names = [i.filename for i in files]
    tops = {n.split("/", 1)[0] for n in names}
    if len(tops) == 1 and all("/" in n for n in names):
        names = [n.split("/", 1)[1] for n in names]
    nested = [n for n in names if "/" in n]
    if nested:
        raise BundleError(f"files must sit at the top level of the archive: '{nested[0]}'", file=archive)
    inflate, ignored = {}, []
    for n, info in zip(names, files):
        if n in inflate:
            raise BundleError(f"'{n}' is in the archive twice", file=archive, field=n)
        if n in KNOWN_FILES:
            inflate[n] = info
        else:
            ignored.append(n)
    return inflate, ignored


def read_zip_safely(
    fh: BinaryIO,
    archive_bytes: int,
    *,
    max_unzipped: int,
    max_ratio: float,
    max_members: int,
    archive: str = "upload.zip",
    parent: str | Path | None = None,
) -> BundleFiles:
    """``{name: path}`` of a bundle zip read from a file object, under every limit; the files sit in a
    temporary folder (under ``parent``) that lives as long as the result or the log parsed from it.

    Files of the archive that are not part of the format map to ``b""`` so that the parser warns
    about them without their content ever being inflated.
    """
    try:
        zf = zipfile.ZipFile(fh)
    except ZIP_READ_ERRORS as exc:
        raise BundleError(f"not a readable zip archive (truncated or corrupt: {exc})", file=archive) from None
    with zf:
        inflate, ignored = plan_zip(
            zf, archive_bytes, max_unzipped=max_unzipped, max_ratio=max_ratio, max_members=max_members, archive=archive
        )
        out = BundleFiles.in_temp_folder(parent)
        jobs = []
        for name, info in inflate.items():

            def chunks(info=info):
                try:
                    with zf.open(info) as src:
                        # a member may not outgrow its header (the declared sizes are within the limit)
                        limit = min(max_unzipped, info.file_size) + 1
                        n = 0
                        while chunk := src.read(min(CHUNK, limit - n)):
                            n += len(chunk)
                            if n >= limit:
                                raise TooLargeError(
                                    f"member '{info.filename}' inflates past its declared size or the limit",
                                    file=archive,
                                    field=info.filename,
                                )
                            yield chunk
                except ZIP_READ_ERRORS as exc:
                    raise BundleError(
                        f"member '{info.filename}' cannot be read (truncated or corrupt: {exc})",
                        file=archive,
                        field=info.filename,
                    ) from None

            jobs.append((name, chunks()))
        try:
            out.write_all(jobs)  # the members inflate in parallel
        except BaseException:
            out.folder.cleanup()  # nothing of a refused upload stays on disk
            raise
        for name in ignored:
            out[name] = b""
        return out


def _size(fh: BinaryIO) -> int:
    pos = fh.tell()
    fh.seek(0, 2)
    n = fh.tell()
    fh.seek(pos)
    return n


def part_names(uploads: list[UploadFile]) -> list[str]:
    """The base file name of every multipart part (a client's folder path dropped); a part without a
    name or a name sent twice is a :class:`BundleError`."""
    names = []
    for up in uploads:
        name = (up.filename or "").replace("\\", "/").rsplit("/", 1)[-1]
        if not name:
            raise BundleError("an uploaded part has no file name")
        if name in names:
            raise BundleError("file uploaded twice", file=name)
        names.append(name)
    return names


def read_upload(uploads: list[UploadFile], settings) -> BundleFiles:
    """Turn the multipart parts into ``{file name: path}`` (one zip, or the files) in a temporary
    folder under ``<data_dir>/tmp`` (the file system of the blob folder: storing links, not copies)."""
    if not uploads:
        raise BundleError("no file in the upload (send one .zip or the bundle's files as 'files')")
    names = part_names(uploads)
    if len(uploads) == 1:
        up, name = uploads[0], names[0]
        up.file.seek(0)
        head = up.file.read(2)
        up.file.seek(0)
        if name.lower().endswith(".zip") or head == b"PK":
            return read_zip_safely(
                up.file,
                _size(up.file),
                max_unzipped=settings.max_unzipped_bytes,
                max_ratio=settings.max_zip_ratio,
                max_members=settings.max_zip_members,
                archive=name,
                parent=_tmp_parent(settings),
            )
    zips = [n for n in names if n.lower().endswith(".zip")]
    if zips:
        raise BundleError("send either one .zip or the separate files, not both", file=zips[0])
    out = BundleFiles.in_temp_folder(_tmp_parent(settings))
    for name, up in zip(names, uploads):
        up.file.seek(0)
        out.write(name, iter(lambda f=up.file: f.read(CHUNK), b""))
    return out


#: a staging folder older than this was left by a process that died mid-upload: removed
STALE_S = 24 * 3600.0


def _tmp_parent(settings) -> Path | None:
    """``<data_dir>/tmp`` when the data folder is usable, else the system's temporary folder.
    Staging folders a killed process left there a day ago or more are removed on the way."""
    import shutil
    import time

    try:
        p = Path(settings.data_dir) / "tmp"
        p.mkdir(parents=True, exist_ok=True)
    except OSError:
        return None
    try:
        now = time.time()
        for d in p.glob("ldvs-bundle-*"):
            if now - d.stat().st_mtime > STALE_S:
                shutil.rmtree(d, ignore_errors=True)
    except OSError:
        pass
    return p
