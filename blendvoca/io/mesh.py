"""Triangle meshes in OBJ and PLY, keeping vertex order exactly.

Readers are written here rather than taken from trimesh because per-vertex
correspondence is the whole point of these files: trimesh's OBJ loader splits
vertices that carry several texture coordinates even with ``process=False``, and
its PLY loader is 5x slower than reading the binary vertex block with numpy, which
matters for VOCASET's ~115k per-frame files (see ``perf/bench_ply_read.py``).
Vertices come back as ``(V, 3)`` float64, faces as ``(F, 3)`` int64.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from blendvoca.errors import DataError, UserError
from blendvoca.io.arrays import float_array
from blendvoca.io.atomic import atomic_write

_PLY_TYPES = {
    "char": "i1", "int8": "i1", "uchar": "u1", "uint8": "u1",
    "short": "i2", "int16": "i2", "ushort": "u2", "uint16": "u2",
    "int": "i4", "int32": "i4", "uint": "u4", "uint32": "u4",
    "float": "f4", "float32": "f4", "double": "f8", "float64": "f8",
}


class MeshFormatError(DataError):
    """A mesh file that does not parse; the message names the file and the problem."""


def read_index_list(path) -> np.ndarray:
    """Whitespace-separated integer indices (landmark or crop lists) as ``(N,) int64``.

    Parameters
    ----------
    path : str or os.PathLike

    Raises
    ------
    DataError
        The file is not text or holds something other than integers (naming the file).
    """
    path = Path(os.fspath(path))
    try:
        text = path.read_text()
    except UnicodeDecodeError as error:
        raise DataError(f"{path}: expected a text file of integer indices "
                        f"({error.reason} at byte {error.start})") from None
    try:
        return np.array([int(tok) for tok in text.split()], dtype=np.int64)
    except ValueError as error:
        raise DataError(f"{path}: expected whitespace-separated integer indices: {error}") from None


# ----------------------------------------------------------------------------- OBJ


def read_obj(path) -> tuple[np.ndarray, np.ndarray]:
    """Vertices and triangles of an OBJ file (``v`` and ``f`` records).

    Polygons are fan-triangulated; ``f a/b/c`` takes the vertex index ``a``;
    negative (relative) indices are resolved. Returns ``(V, 3) float64``,
    ``(F, 3) int64`` zero-based.
    """
    with open(path, encoding="utf-8", errors="replace") as f:
        return parse_obj(f.read(), where=path)


def parse_obj(text: str, *, where="<obj>") -> tuple[np.ndarray, np.ndarray]:
    """`read_obj` on the text of an OBJ file; ``where`` names it in errors."""
    vertices, faces = [], []
    for lineno, line in enumerate(text.splitlines(), 1):
        if line.startswith("v "):
            parts = line.split()
            if len(parts) < 4:
                raise MeshFormatError(f"{where}:{lineno}: vertex with fewer than 3 coordinates: {line.strip()!r}")
            try:
                vertices.append([float(x) for x in parts[1:4]])
            except ValueError:
                raise MeshFormatError(f"{where}:{lineno}: vertex coordinates are not numbers: {line.strip()!r}") from None
        elif line.startswith("f "):
            try:
                idx = [int(tok.split("/")[0]) for tok in line.split()[1:]]
            except ValueError:
                raise MeshFormatError(f"{where}:{lineno}: face indices are not integers: {line.strip()!r}") from None
            if len(idx) < 3 or 0 in idx:
                raise MeshFormatError(f"{where}:{lineno}: expected a face of >= 3 vertex indices (1-based or "
                                      f"negative, never 0): {line.strip()!r}")
            idx = [i - 1 if i > 0 else len(vertices) + i for i in idx]
            faces.extend([idx[0], idx[k], idx[k + 1]] for k in range(1, len(idx) - 1))
    if not vertices:
        raise MeshFormatError(f"{where}: no vertices ('v x y z' lines) found")
    V = np.array(vertices, dtype=np.float64)
    F = np.array(faces, dtype=np.int64).reshape(-1, 3)
    if F.size and (F.min() < 0 or F.max() >= len(V)):
        raise MeshFormatError(f"{where}: face index out of range [1, {len(V)}]")
    return V, F


def obj_face_records(faces) -> str:
    """The ``f`` records of ``faces (F, 3)`` as :func:`write_obj` writes them (1-based)."""
    F = np.asarray(faces, dtype=np.int64)
    # One %-format over all records (the same bytes as formatting line by line, ~4x faster).
    return ("f %d %d %d\n" * len(F)) % tuple((F + 1).ravel().tolist())


def write_obj(path, vertices, faces, *, face_records: str | None = None) -> None:
    """Write ``v`` and ``f`` records (vertex order kept; 9 significant digits).

    ``face_records``: :func:`obj_face_records` of ``faces``, formatted once for
    many meshes of one topology (a rig's blendshapes).
    """
    V = _vertices(vertices, path)
    text = ("v %.9g %.9g %.9g\n" * len(V)) % tuple(V.ravel().tolist())
    text += obj_face_records(faces) if face_records is None else face_records
    with atomic_write(path, "w", encoding="utf-8", newline="\n") as f:
        f.write(text or "\n")


# ----------------------------------------------------------------------------- PLY


def _parse_ply_header(data: bytes, path) -> tuple[str, list[dict], int]:
    end = data.find(b"end_header")
    if not data.startswith(b"ply") or end < 0:
        raise MeshFormatError(f"{path}: not a PLY file (no 'ply' magic or no 'end_header')")
    newline = data.find(b"\n", end)
    if newline < 0:
        raise MeshFormatError(f"{path}: no line break after 'end_header'")
    body_start = newline + 1
    fmt, elements = None, []
    for lineno, raw in enumerate(data[:end].decode("ascii", errors="replace").splitlines()[1:], 2):
        tokens = raw.split()
        if not tokens or tokens[0] in ("comment", "obj_info"):
            continue
        where = f"{path}: header line {lineno} {raw.strip()!r}"
        if tokens[0] == "format":
            if len(tokens) < 2:
                raise MeshFormatError(f"{where}: expected 'format <ascii|binary_little_endian|binary_big_endian> 1.0'")
            fmt = tokens[1]
        elif tokens[0] == "element":
            if len(tokens) != 3 or not tokens[2].isdigit():
                raise MeshFormatError(f"{where}: expected 'element <name> <count>' with a count >= 0")
            elements.append({"name": tokens[1], "count": int(tokens[2]), "props": []})
        elif tokens[0] == "property":
            if not elements:
                raise MeshFormatError(f"{where}: property before any element")
            if len(tokens) < 3:
                raise MeshFormatError(f"{where}: expected 'property <type> <name>'")
            types = tokens[2:4] if tokens[1] == "list" else tokens[1:2]
            for t in types:
                if t not in _PLY_TYPES:
                    raise MeshFormatError(f"{where}: unknown property type {t!r}; expected one of {sorted(_PLY_TYPES)}")
            if tokens[1] == "list":
                if len(tokens) != 5:
                    raise MeshFormatError(f"{where}: expected 'property list <count type> <index type> <name>'")
                elements[-1]["props"].append((tokens[4], _PLY_TYPES[tokens[2]], _PLY_TYPES[tokens[3]]))
            else:
                if len(tokens) != 3:
                    raise MeshFormatError(f"{where}: expected 'property <type> <name>'")
                elements[-1]["props"].append((tokens[2], _PLY_TYPES[tokens[1]], None))
        elif tokens[0] not in ("end_header", "ply"):
            raise MeshFormatError(f"{where}: unknown header keyword {tokens[0]!r}")
    if fmt not in ("ascii", "binary_little_endian", "binary_big_endian"):
        raise MeshFormatError(f"{path}: unsupported PLY format {fmt!r}; expected ascii, binary_little_endian "
                              "or binary_big_endian")
    for element in elements:
        if element["name"] == "vertex":
            names = [p[0] for p in element["props"]]
            missing = [c for c in "xyz" if c not in names]
            if missing:
                raise MeshFormatError(f"{path}: the vertex element lacks properties {missing} (has {names})")
            if any(p[2] is not None for p in element["props"]):
                raise MeshFormatError(f"{path}: list properties on vertices are not supported")
    return fmt, elements, body_start


def _vertex_dtype(props, endian: str, path="<ply>") -> np.dtype:
    if any(p[2] is not None for p in props):
        raise MeshFormatError(f"{path}: list properties are only supported on faces")
    try:
        return np.dtype([(name, endian + t) for name, t, _ in props])
    except (ValueError, TypeError) as error:  # e.g. a property name given twice
        raise MeshFormatError(f"{path}: bad property list {[p[0] for p in props]}: {error}") from None


def _read_ply_bytes(data: bytes, path, *, with_faces: bool) -> tuple[np.ndarray, np.ndarray | None]:
    fmt, elements, offset = _parse_ply_header(data, path)
    names = [e["name"] for e in elements]
    if "vertex" not in names:
        raise MeshFormatError(f"{path}: no 'vertex' element in the PLY header")
    try:
        if fmt == "ascii":
            V, F = _read_ply_ascii(data[offset:].decode("ascii", errors="replace"), elements, path, with_faces)
        else:
            V, F = _read_ply_binary(data, offset, elements, "<" if fmt == "binary_little_endian" else ">", path,
                                    with_faces)
    except MeshFormatError:
        raise
    except (ValueError, IndexError, OverflowError, TypeError) as error:  # anything the checks did not foresee
        raise MeshFormatError(f"{path}: malformed {fmt} PLY body: {error}") from None
    if F is not None and F.size and (F.min() < 0 or F.max() >= len(V)):
        raise MeshFormatError(f"{path}: face vertex index out of range [0, {len(V)}): min {F.min()}, max {F.max()}")
    return V, F


def _read_ply_binary(data, offset, elements, endian, path, with_faces):
    V = F = None
    for element in elements:
        if element["name"] == "vertex":
            dtype = _vertex_dtype(element["props"], endian, path)
            nbytes = dtype.itemsize * element["count"]
            if offset + nbytes > len(data):
                raise MeshFormatError(
                    f"{path}: truncated: header declares {element['count']} vertices "
                    f"({nbytes} bytes) but only {len(data) - offset} bytes follow the header"
                )
            block = np.frombuffer(data, dtype=dtype, count=element["count"], offset=offset)
            V = np.stack([block["x"], block["y"], block["z"]], axis=1).astype(np.float64).reshape(-1, 3)
            offset += nbytes
        elif element["name"] == "face":
            if not with_faces:
                break
            F, offset = _read_binary_faces(data, offset, element, endian, path)
        else:
            if element["count"] and V is not None and (F is not None or not with_faces):
                break
            dtype = _vertex_dtype(element["props"], endian, path)
            offset += dtype.itemsize * element["count"]
    return V, F


def _read_binary_faces(data, offset, element, endian, path):
    props = element["props"]
    count = element["count"]
    if len(props) == 1 and props[0][2] is not None:
        count_t, index_t = props[0][1], props[0][2]
        # Fast path: every face a triangle, so each record is count + 3 indices.
        record = np.dtype([("n", endian + count_t), ("i", endian + index_t, 3)])
        nbytes = record.itemsize * count
        if offset + nbytes <= len(data):
            block = np.frombuffer(data, dtype=record, count=count, offset=offset)
            if count == 0 or np.all(block["n"] == 3):
                return block["i"].astype(np.int64), offset + nbytes
    # General path: polygons of any size, fan-triangulated.
    faces = []
    for number in range(count):
        row = []
        for _name, t, index_t in props:
            size = np.dtype(t).itemsize
            if offset + size > len(data):
                raise MeshFormatError(f"{path}: truncated inside the face block (face {number} of {count})")
            if index_t is None:
                offset += size
                continue
            n = int(np.frombuffer(data, endian + t, 1, offset)[0])
            offset += size
            if n < 0 or offset + n * np.dtype(index_t).itemsize > len(data):
                raise MeshFormatError(f"{path}: truncated inside the face block (face {number} of {count})")
            row = np.frombuffer(data, endian + index_t, n, offset).tolist()
            offset += n * np.dtype(index_t).itemsize
        faces.extend([row[0], row[k], row[k + 1]] for k in range(1, len(row) - 1))
    return np.array(faces, dtype=np.int64).reshape(-1, 3), offset


def _read_ply_ascii(text, elements, path, with_faces):
    lines = iter(text.splitlines())
    V = F = None
    for element in elements:
        rows = []
        for i in range(element["count"]):
            try:
                rows.append(next(lines).split())
            except StopIteration:
                raise MeshFormatError(f"{path}: truncated: element {element['name']!r} declares {element['count']} rows, found {i}") from None
        if element["name"] == "vertex":
            names = [p[0] for p in element["props"]]
            cols = [names.index(c) for c in "xyz"]
            for i, r in enumerate(rows):
                if len(r) < len(names):
                    raise MeshFormatError(f"{path}: vertex {i}: {len(r)} values, expected {len(names)} ({names})")
            try:
                V = np.array([[float(r[c]) for c in cols] for r in rows], dtype=np.float64).reshape(-1, 3)
            except ValueError as error:
                raise MeshFormatError(f"{path}: vertex block: {error}") from None
        elif element["name"] == "face" and with_faces:
            faces = []
            for i, r in enumerate(rows):
                try:
                    n = int(r[0])
                    idx = [int(x) for x in r[1 : 1 + n]]
                except (ValueError, IndexError):
                    raise MeshFormatError(f"{path}: face {i}: expected '<n> <i1> ... <in>', got {' '.join(r)!r}") from None
                if n < 0 or len(idx) != n:
                    raise MeshFormatError(f"{path}: face {i}: declares {n} indices, has {len(idx)}")
                faces.extend([idx[0], idx[k], idx[k + 1]] for k in range(1, n - 1))
            F = np.array(faces, dtype=np.int64).reshape(-1, 3)
    return V, F


def read_ply(path) -> tuple[np.ndarray, np.ndarray]:
    """Vertices ``(V, 3) float64`` and triangles ``(F, 3) int64`` (empty if none)."""
    V, F = _read_ply_bytes(Path(path).read_bytes(), path, with_faces=True)
    return V, (F if F is not None else np.zeros((0, 3), np.int64))


def read_ply_vertices(path) -> np.ndarray:
    """Only the vertices of a PLY file, ``(V, 3) float64``: the fast path."""
    return _read_ply_bytes(Path(path).read_bytes(), path, with_faces=False)[0]


def read_ply_sequence(paths: Sequence, *, num_vertices: int | None = None) -> np.ndarray:
    """Stack the vertices of many same-topology PLY frames, ``(T, V, 3) float64``.

    Raises
    ------
    MeshFormatError
        Naming the frame (index and file) that is truncated or has another vertex count.
    """
    paths = list(paths)
    if not paths:
        raise UserError("read_ply_sequence: no frame files given")
    out = None
    for t, path in enumerate(paths):
        try:
            V = read_ply_vertices(path)
        except MeshFormatError as error:
            raise MeshFormatError(f"frame {t + 1} of {len(paths)}: {error}") from None
        expected = num_vertices if num_vertices is not None else (out.shape[1] if out is not None else len(V))
        if len(V) != expected:
            raise MeshFormatError(f"frame {t + 1} of {len(paths)} ({path}): {len(V)} vertices, expected {expected}")
        if out is None:
            out = np.empty((len(paths), expected, 3), dtype=np.float64)
        out[t] = V
    return out


def ply_header(num_vertices: int, num_faces: int | None = None, *, binary: bool = True) -> bytes:
    """The header `write_ply` writes: float32 x, y, z and, with ``num_faces``, triangles."""
    header = ["ply", f"format {'binary_little_endian' if binary else 'ascii'} 1.0", f"element vertex {num_vertices}",
              "property float x", "property float y", "property float z"]
    if num_faces is not None:
        header += [f"element face {num_faces}", "property list uchar int vertex_indices"]
    header.append("end_header")
    return ("\n".join(header) + "\n").encode("ascii")


def ply_face_block(faces) -> bytes:
    """The binary face records `write_ply` writes: a uchar 3 and three little-endian int32."""
    F = np.asarray(faces, dtype=np.int64)
    record = np.empty(len(F), dtype=[("n", "u1"), ("i", "<i4", 3)])
    record["n"] = 3
    record["i"] = F
    return record.tobytes()


def write_ply(path, vertices, faces=None, *, binary: bool = True) -> None:
    """Write a PLY file with float32 vertices and (optionally) int32 triangles.

    float32 is what VOCASET and most scanners store; pass float64 data and expect
    rounding to float32 (about 1e-7 relative).
    """
    V = _vertices(vertices, path)
    F = np.zeros((0, 3), np.int64) if faces is None else np.asarray(faces, dtype=np.int64)
    with atomic_write(path, "wb") as f:
        f.write(ply_header(len(V), None if faces is None else len(F), binary=binary))
        if binary:
            f.write(V.astype("<f4").tobytes())
            if faces is not None:
                f.write(ply_face_block(F))
        else:
            lines = ["%.9g %.9g %.9g" % tuple(v) for v in V.astype(np.float32)]
            lines += ["3 %d %d %d" % tuple(t) for t in F]
            f.write(("\n".join(lines) + "\n").encode("ascii"))


# ----------------------------------------------------------------------------- any


_READERS = {".obj": read_obj, ".ply": read_ply}
_WRITERS = {".obj": write_obj, ".ply": write_ply}


def read_mesh(path) -> tuple[np.ndarray, np.ndarray]:
    """Read an OBJ or PLY mesh (by suffix), keeping vertex order.

    Parameters
    ----------
    path : str or os.PathLike

    Returns
    -------
    vertices : (V, 3) float64 ndarray
    faces : (F, 3) int64 ndarray

    Raises
    ------
    UserError
        A suffix other than .obj / .ply.
    FileNotFoundError
        No file at ``path``.
    MeshFormatError
        The file does not parse (naming the file and line or element).
    """
    path = Path(os.fspath(path))
    suffix = path.suffix.lower()
    if suffix not in _READERS:
        raise UserError(f"{path}: unsupported mesh format {suffix!r}; expected one of {sorted(_READERS)}")
    if not path.is_file():
        raise FileNotFoundError(f"mesh file not found: {path}")
    return _READERS[suffix](path)


def write_mesh(path, vertices, faces) -> None:
    """Write an OBJ or PLY mesh (by suffix): ``vertices (V, 3)`` of any real dtype, ``faces (F, 3)``."""
    suffix = Path(os.fspath(path)).suffix.lower()
    if suffix not in _WRITERS:
        raise UserError(f"{path}: unsupported mesh format {suffix!r}; expected .obj or .ply")
    _WRITERS[suffix](path, vertices, faces)


def _vertices(vertices, where) -> np.ndarray:
    """``(V, 3)`` float64 vertices to write, or a :class:`UserError` naming ``where``."""
    V = float_array(vertices, where=str(where), name="vertices", shape="(V, 3)")
    if V.ndim != 2 or V.shape[1] != 3:
        raise UserError(f"{where}: vertices must be (V, 3), got shape {V.shape}")
    return V
