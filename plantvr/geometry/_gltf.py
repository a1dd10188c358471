"""glTF 2.0 binary buffer packing shared by the .glb writers (spec 000_treewand §3; spec 004_treesketch §4.6).

:class:`GltfBuffer` packs arrays into the one binary buffer of a ``.glb`` and keeps the bufferView and accessor
records that describe them, as plain glTF JSON dicts (numpy only). Used by :mod:`plantvr.geometry.gltf_skin`
(which turns the dicts into pygltflib objects) and :mod:`plantvr.landscape.gltf` (which writes the JSON itself).
"""
from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

__all__ = ["ARRAY_BUFFER", "ELEMENT_ARRAY_BUFFER", "GltfBuffer", "check_glb_path"]

ARRAY_BUFFER, ELEMENT_ARRAY_BUFFER = 34962, 34963          # bufferView targets: vertex data, indices
_COMPONENT_TYPE = {np.dtype(np.float32): 5126, np.dtype(np.uint32): 5125, np.dtype(np.uint16): 5123,
                   np.dtype(np.uint8): 5121}
_N_COMPONENTS = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT4": 16}


def check_glb_path(path) -> Path:
    """``path`` as a Path; a ValueError unless it ends in ``.glb`` (any case)."""
    path = Path(path)
    if path.suffix.lower() != ".glb":
        raise ValueError(f"path must end in .glb, got {path.suffix!r}")
    return path


class GltfBuffer:
    """The binary chunk of a ``.glb`` being filled, with its bufferViews and accessors.

    Every array starts on a 4-byte boundary (zero padding), as glTF requires for float and uint32 data.

    Attributes
    ----------
    views : list of dict
        One bufferView per added array (``buffer``, ``byteOffset``, ``byteLength`` and ``target`` when given).
    accessors : list of dict
        One accessor per added array (``bufferView``, ``componentType``, ``count``, ``type``, ``min``/``max``).
    size : int
        Bytes written so far, padding included.
    """

    def __init__(self) -> None:
        self.views: list[dict[str, Any]] = []
        self.accessors: list[dict[str, Any]] = []
        self.size = 0
        self._chunks: list[bytes] = []

    def add(self, arr: np.ndarray, atype: str, *, target: int | None = None, minmax: bool = False) -> int:
        """Append ``arr`` and return the index of its accessor.

        Parameters
        ----------
        arr : ndarray of float32, uint32, uint16 or uint8
            The data, row-major; ``arr.size`` a multiple of the components of ``atype``.
        atype : {"SCALAR", "VEC2", "VEC3", "VEC4", "MAT4"}
            Accessor type.
        target : int, optional
            bufferView target (:data:`ARRAY_BUFFER`, :data:`ELEMENT_ARRAY_BUFFER`); omitted when None.
        minmax : bool
            Record per-component ``min`` and ``max`` (glTF requires them on POSITION).

        Returns
        -------
        int
            Accessor index.
        """
        arr = np.ascontiguousarray(arr)
        if arr.dtype not in _COMPONENT_TYPE:
            raise ValueError(f"arr must be float32, uint32, uint16 or uint8, got {arr.dtype}")
        if atype not in _N_COMPONENTS:
            raise ValueError(f"atype must be one of {tuple(_N_COMPONENTS)}, got {atype!r}")
        data = arr.tobytes()
        pad = (-self.size) % 4
        if pad:
            self._chunks.append(b"\0" * pad)
            self.size += pad
        view: dict[str, Any] = {"buffer": 0, "byteOffset": self.size, "byteLength": len(data)}
        if target is not None:
            view["target"] = target
        self.views.append(view)
        self._chunks.append(data)
        self.size += len(data)
        ncomp = _N_COMPONENTS[atype]
        count = int(arr.size // ncomp)
        acc: dict[str, Any] = {"bufferView": len(self.views) - 1, "componentType": _COMPONENT_TYPE[arr.dtype],
                               "count": count, "type": atype}
        if minmax:
            flat = arr.reshape(count, ncomp)
            acc["min"] = flat.min(0).astype(float).tolist()
            acc["max"] = flat.max(0).astype(float).tolist()
        self.accessors.append(acc)
        return len(self.accessors) - 1

    def blob(self) -> bytes:
        """The buffer's bytes, zero-padded to a multiple of 4."""
        return b"".join(self._chunks) + b"\0" * ((-self.size) % 4)
