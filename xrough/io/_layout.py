"""What the headers of formats read through SurfaceTopography state about the file's layout.

SurfaceTopography reads the data where the header says it is and does not compare the
header's sizes and offsets with the file: a byte cut from a header comment or inserted
before the data shifts every value (an Alicona ``.al3d`` then reads heights of
``+-2.5e38 m``). :func:`check_layout` does for the bridged formats what the native readers
do: it reads the header's sizes and offsets and refuses a file whose size disagrees.

- Alicona AL3D: a tag list (``Cols``, ``Rows``, ``DepthImageOffset``,
  ``TextureImageOffset``, ``NumberOfPlanes``), a 256-byte comment ending in CR LF, the
  depth image (rows of 32-bit floats padded to 8 bytes) and the texture planes (rows of
  8- or 16-bit samples padded to 8 samples); the last section ends where the file ends.
- Nanosurf NID/EZD: an INI-style text header whose data sets (``Points`` x ``Lines`` x
  ``SaveBits``) follow the ``#!`` marker back to back, up to the end of the file.
- Molecular Imaging MI: a text header up to its ``data BINARY`` (or ``BINARY_32``) line,
  then one ``yPixels`` x ``xPixels`` buffer of 16- (32-)bit integers per ``bufferLabel``,
  up to the end of the file.

Every failure is a ``ValueError`` naming the file (:func:`xrough.io._common.fail`).
"""

from __future__ import annotations

from pathlib import Path

from ._common import fail

__all__ = ["check_layout"]

#: Longest header read while looking for its end (a larger one is taken as damaged).
_MAX_HEADER = 16 << 20

_AL3D_MAGIC = b"AliconaImaging\x00\r\n"
_AL3D_TAG = 52  # key (20 bytes), value (30 bytes), CR LF
_AL3D_COMMENT = 256


def check_layout(path: Path, reader: str) -> None:
    """Refuse a file whose header's sizes and offsets disagree with the file's size.

    Parameters
    ----------
    path : Path
        The file.
    reader : str
        Name of SurfaceTopography's reader class (``AL3DReader``...); formats without a
        check here pass unchecked.

    Raises
    ------
    ValueError
        Truncated file, bytes inserted or deleted, or a header stating impossible
        offsets (the message names the file, the header entries and the byte counts).
    """
    check = _CHECKS.get(reader)
    if check is not None:
        check(path, path.stat().st_size)


def _whole(path: Path, what: str, value: str) -> int:
    try:
        number = int(value.strip())
    except ValueError:
        raise fail(path, f"corrupted header: {what} {value.strip()[:40]!r} is not a whole "
                         "number") from None
    if number < 0:
        raise fail(path, f"corrupted header: {what} {number} is negative")
    return number


def _ends(path: Path, size: int, last: int, what: str) -> None:
    """Refuse a file that does not end where its header's last section ends."""
    if size < last:
        raise fail(path, f"truncated file: {what} ends at byte {last}, the file has "
                         f"{size} bytes")
    if size > last:
        raise fail(path, f"the file has {size} bytes, {size - last} more than its header "
                         f"accounts for ({what} ends at byte {last}): bytes inserted into "
                         "the file shift the data")


# ------------------------------------------------------------------------------- AL3D


def _al3d_tags(path: Path, head: bytes) -> tuple[dict[str, str], int]:
    """Return the AL3D header's tags and the byte where the comment after them ends."""
    def tag(pos: int) -> tuple[str, str]:
        if len(head) < pos + _AL3D_TAG:
            raise fail(path, f"truncated file: the AL3D header ends at byte {len(head)}, "
                             f"inside its tag list")
        chunk = head[pos:pos + _AL3D_TAG]
        key = chunk[:20].split(b"\0")[0].decode("latin-1")
        if chunk[50:] != b"\r\n":
            raise fail(path, f"corrupted AL3D header: the tag {key[:20]!r} at byte {pos} "
                             "does not end with CR LF (bytes inserted or deleted)")
        return key, chunk[20:50].split(b"\0")[0].decode("latin-1")

    pos = len(_AL3D_MAGIC)
    tags = dict([tag(pos), tag(pos + _AL3D_TAG)])
    count = _whole(path, "TagCount", tags.get("TagCount", ""))
    pos += 2 * _AL3D_TAG
    if pos + count * _AL3D_TAG + _AL3D_COMMENT > len(head):
        raise fail(path, f"truncated file: the AL3D header's {count} tags and comment need "
                         f"{pos + count * _AL3D_TAG + _AL3D_COMMENT} bytes, the file has "
                         f"{len(head)}")
    for k in range(count):
        key, value = tag(pos + k * _AL3D_TAG)
        tags.setdefault(key, value)
    end = pos + count * _AL3D_TAG + _AL3D_COMMENT
    if head[end - 2:end] != b"\r\n":
        raise fail(path, f"corrupted AL3D header: the comment does not end with CR LF at "
                         f"byte {end} (bytes inserted or deleted)")
    return tags, end


def _check_al3d(path: Path, size: int) -> None:
    with open(path, "rb") as fh:
        head = fh.read(len(_AL3D_MAGIC) + 2 * _AL3D_TAG)
        if not head.startswith(_AL3D_MAGIC):
            raise fail(path, "not an AL3D file (no 'AliconaImaging' magic)")
        field = head[len(_AL3D_MAGIC) + _AL3D_TAG + 20:len(_AL3D_MAGIC) + _AL3D_TAG + 50]
        count = _whole(path, "TagCount", field.split(b"\0")[0].decode("latin-1"))
        head += fh.read(min(count * _AL3D_TAG + _AL3D_COMMENT, _MAX_HEADER))
    tags, header_end = _al3d_tags(path, head)

    def number(key: str, default=None) -> int | None:
        return default if key not in tags else _whole(path, key, tags[key])

    nx, ny = number("Cols"), number("Rows")
    depth = number("DepthImageOffset")
    if nx is None or ny is None or depth is None:
        return  # SurfaceTopography refuses it
    if depth < header_end:
        raise fail(path, f"corrupted AL3D header: DepthImageOffset {depth} lies inside the "
                         f"{header_end}-byte header")
    depth_end = depth + ny * ((4 * nx + 7) // 8 * 8)
    what = f"the depth image (DepthImageOffset {depth}, Rows {ny} x Cols {nx} floats)"
    if depth_end > size:
        raise fail(path, f"truncated file: {what} ends at byte {depth_end}, the file has "
                         f"{size} bytes")
    texture, planes = number("TextureImageOffset", 0) or 0, number("NumberOfPlanes")
    icon = number("IconOffset", 0) or 0
    if texture and texture < depth_end and texture >= depth:
        raise fail(path, f"corrupted AL3D header: TextureImageOffset {texture} lies inside "
                         f"{what}")
    if icon and max(texture, depth) < icon < size:
        return  # an icon of a size the header does not state comes last
    if not texture or texture < depth:
        _ends(path, size, depth_end, what)
        return
    if planes is None:
        return
    # texture planes of 8-bit (or 16-bit) samples, rows padded to 8 samples
    ends = [texture + planes * ny * ((nx + 7) // 8 * 8) * width for width in (1, 2)]
    if size not in ends:
        _ends(path, size, ends[0], f"the texture (TextureImageOffset {texture}, "
                                   f"NumberOfPlanes {planes} of Rows {ny} x Cols {nx})")


# -------------------------------------------------------------------------------- NID


def _nid_header(path: Path) -> tuple[str, int]:
    """Return the text before a NID/EZD file's ``#!`` marker and where the data starts."""
    with open(path, "rb") as fh:
        head = b""
        while True:
            block = fh.read(1 << 16)
            head += block
            at = head.find(b"\n#!", max(0, len(head) - len(block) - 2))
            if at >= 0:
                return head[:at].decode("latin-1"), at + 3
            if not block or len(head) > _MAX_HEADER:
                break
    raise fail(path, "no '#!' line ending the NID header (truncated file?)")


def _check_nid(path: Path, size: int) -> None:
    text, start = _nid_header(path)
    sections: dict[str, dict[str, str]] = {}
    current = sections.setdefault("DataSet", {})
    for line in text.splitlines():
        line = line.strip()
        if line.startswith("[") and line.endswith("]"):
            current = sections.setdefault(line[1:-1], {})
        elif "=" in line:
            key, value = line.split("=", 1)
            current.setdefault(key, value)
    top = sections.get("DataSet", {})
    total = 0
    for group in range(_whole(path, "DataSet GroupCount", top.get("GroupCount", "0"))):
        for channel in range(_whole(path, f"DataSet Gr{group}-Count",
                                    top.get(f"Gr{group}-Count", "0"))):
            name = top.get(f"Gr{group}-Ch{channel}")
            entries = sections.get(name) if name else None
            if entries is None:
                continue
            points, lines, bits = (_whole(path, f"[{name}] {key}", entries.get(key, ""))
                                   for key in ("Points", "Lines", "SaveBits"))
            total += points * lines * (bits // 8)
    _ends(path, size, start + total, f"the data sets (Points x Lines x SaveBits after the "
                                     f"'#!' line at byte {start - 2}, {total} bytes)")


# --------------------------------------------------------------------------------- MI


def _check_mi(path: Path, size: int) -> None:
    entries: dict[str, str] = {}
    buffers = 0
    with open(path, "rb") as fh:
        while fh.tell() < _MAX_HEADER:
            line = fh.readline()
            if not line:
                raise fail(path, "no 'data' line ending the MI header (truncated file?)")
            if line.startswith(b" "):
                continue
            key = line[:14].decode("latin-1").strip()
            value = line[14:].decode("latin-1").strip()
            if key == "bufferLabel":
                buffers += 1
            if key == "data":
                start = fh.tell()
                break
            entries.setdefault(key, value)
        else:
            raise fail(path, "no 'data' line ending the MI header")
    if value not in ("BINARY", "BINARY_32", ""):
        return  # text data: SurfaceTopography refuses it
    width = 4 if value == "BINARY_32" else 2
    nx = _whole(path, "xPixels", entries.get("xPixels", ""))
    ny = _whole(path, "yPixels", entries.get("yPixels", ""))
    _ends(path, size, start + buffers * nx * ny * width,
          f"the {buffers} buffers of yPixels {ny} x xPixels {nx} x {width} bytes after the "
          f"header's data line (byte {start})")


#: The checks, by the name of SurfaceTopography's reader class.
_CHECKS = {"AL3DReader": _check_al3d, "EZDReader": _check_nid, "MIReader": _check_mi}
