"""The one glTF 2.0 writer: a buffer packer and a document builder behind every .glb/.gltf PlantVR writes
(spec 000_treewand §3; spec 000_vine §2.7; spec 004_treesketch §4.6; issue 21).

:class:`GltfBuffer` packs arrays into the one binary buffer and keeps the bufferView and accessor records that
describe them. :class:`Gltf` builds the JSON document around it (meshes, materials with PNG textures, nodes,
skins, animations); :func:`emit_gltf`, the ``glb`` and ``gltf`` rows of the writer registry
(:data:`plantvr.io.writers.WRITERS`), writes it as ``.glb`` (one file) or ``.gltf`` (JSON plus ``<stem>.bin``)
through the registry's atomic resolver; :func:`parts_document` builds the document of a list of parts. numpy, json and struct only: no trimesh or pygltflib on the write path (they are the
readers the tests use as oracles). Instancing is by nodes sharing a mesh (:func:`write_glb`).

Every writer calls it: tree meshes (:func:`plantvr.io.tree.export_tree`), the skinned tree
(:func:`plantvr.io.tree.export_skinned_glb`), landscapes and forests (:mod:`plantvr.io.landscape`), label and
segmentation meshes (:mod:`plantvr.io.labels`), subdivision surfaces (:func:`plantvr.io.mesh.export_mesh`) and
billboards (:func:`write_textured`).
"""
from __future__ import annotations

import io
import json
import struct
from pathlib import Path
from typing import Any

import numpy as np

from plantvr._fileio import atomic_write  # noqa: F401  (kept importable: failure tests patch it here)
from plantvr._validation import MAX_COUNT, check_array

from .parts import Part, as_parts, check_image, format_of, save_with

__all__ = [
    "ARRAY_BUFFER",
    "ELEMENT_ARRAY_BUFFER",
    "MAX_GLB_COORD",
    "Gltf",
    "GltfBuffer",
    "check_glb_path",
    "emit_gltf",
    "parts_document",
    "write_glb",
    "write_mesh",
    "write_textured",
]

ARRAY_BUFFER, ELEMENT_ARRAY_BUFFER = 34962, 34963          # bufferView targets: vertex data, indices
_COMPONENT_TYPE = {np.dtype(np.float32): 5126, np.dtype(np.uint32): 5125, np.dtype(np.uint16): 5123,
                   np.dtype(np.uint8): 5121}
_N_COMPONENTS = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT4": 16}

#: Largest coordinate written (float32 positions and transforms stay exact enough and finite).
MAX_GLB_COORD = 1e12
_DEFAULT_RGBA = (0.38, 0.26, 0.16, 1.0)


def check_glb_path(path) -> Path:
    """``path`` as a Path; a ValueError unless it ends in ``.glb`` (any case)."""
    path = Path(path)
    if path.suffix.lower() != ".glb":
        raise ValueError(f"path must end in .glb, got {path.suffix!r}")
    return path


class GltfBuffer:
    """The binary chunk of a glTF file being filled, with its bufferViews and accessors.

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

    def add_view(self, data: bytes, *, target: int | None = None) -> int:
        """Append raw bytes (an image) as one 4-byte aligned bufferView; return its index."""
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
        return len(self.views) - 1

    def add(self, arr: np.ndarray, atype: str, *, target: int | None = None, minmax: bool = False,
            normalized: bool = False) -> int:
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
        normalized : bool
            Integer data read as [0, 1] (vertex colours).

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
        view = self.add_view(arr.tobytes(), target=target)
        ncomp = _N_COMPONENTS[atype]
        count = int(arr.size // ncomp)
        acc: dict[str, Any] = {"bufferView": view, "componentType": _COMPONENT_TYPE[arr.dtype],
                               "count": count, "type": atype}
        if normalized:
            acc["normalized"] = True
        if minmax:
            flat = arr.reshape(count, ncomp)
            acc["min"] = flat.min(0).astype(float).tolist()
            acc["max"] = flat.max(0).astype(float).tolist()
        self.accessors.append(acc)
        return len(self.accessors) - 1

    def blob(self) -> bytes:
        """The buffer's bytes, zero-padded to a multiple of 4."""
        return b"".join(self._chunks) + b"\0" * ((-self.size) % 4)


def _png(image: np.ndarray) -> bytes:
    from PIL import Image

    img = np.asarray(image)
    if img.dtype != np.uint8 or img.ndim != 3 or img.shape[2] not in (3, 4):
        raise ValueError(f"image must be (H, W, 3 or 4) uint8, got {img.dtype} {img.shape}")
    out = io.BytesIO()
    Image.fromarray(img).save(out, format="PNG")
    return out.getvalue()


class Gltf:
    """A glTF 2.0 document being built: JSON lists beside one :class:`GltfBuffer`.

    Add materials, meshes and nodes (and optionally skins and animations), then :meth:`write` a ``.glb`` or a
    ``.gltf``. Each ``add_*`` returns the index of what it added.

    Parameters
    ----------
    generator : str
        ``asset.generator``.
    """

    def __init__(self, generator: str = "PlantVR") -> None:
        self.buffer = GltfBuffer()
        self.asset = {"version": "2.0", "generator": generator}
        self.scenes: list[dict[str, Any]] = []
        self.nodes: list[dict[str, Any]] = []
        self.meshes: list[dict[str, Any]] = []
        self.materials: list[dict[str, Any]] = []
        self.textures: list[dict[str, Any]] = []
        self.images: list[dict[str, Any]] = []
        self.samplers: list[dict[str, Any]] = []
        self.skins: list[dict[str, Any]] = []
        self.animations: list[dict[str, Any]] = []

    def add_texture(self, image: np.ndarray) -> int:
        """An (H, W, 3|4) uint8 image, embedded as PNG, with a repeating linear sampler."""
        view = self.buffer.add_view(_png(image))
        self.images.append({"bufferView": view, "mimeType": "image/png"})
        if not self.samplers:
            self.samplers.append({"magFilter": 9729, "minFilter": 9987, "wrapS": 10497, "wrapT": 10497})
        self.textures.append({"sampler": 0, "source": len(self.images) - 1})
        return len(self.textures) - 1

    def add_material(self, name: str, *, rgba=None, texture: np.ndarray | None = None, metallic: float = 0.0,
                     roughness: float = 0.9, double_sided: bool = False, alpha_mode: str | None = None,
                     alpha_cutoff: float | None = None) -> int:
        """A PBR metallic-roughness material: a base colour factor and/or a base colour texture."""
        pbr: dict[str, Any] = {}
        if rgba is not None:
            pbr["baseColorFactor"] = [float(c) for c in rgba]
        if texture is not None:
            pbr["baseColorTexture"] = {"index": self.add_texture(texture)}
        pbr["metallicFactor"] = float(metallic)
        pbr["roughnessFactor"] = float(roughness)
        mat: dict[str, Any] = {"name": name, "pbrMetallicRoughness": pbr, "doubleSided": bool(double_sided)}
        if alpha_mode is not None:
            mat["alphaMode"] = alpha_mode
        if alpha_cutoff is not None:
            mat["alphaCutoff"] = float(alpha_cutoff)
        self.materials.append(mat)
        return len(self.materials) - 1

    def primitive(self, vertices, faces, *, normals=None, uv=None, colors=None, joints=None, weights=None,
                  material: int | None = None) -> dict[str, Any]:
        """A triangle primitive: float32 POSITION (with min/max), optional NORMAL, TEXCOORD_0, COLOR_0
        (uint8 normalized), JOINTS_0, WEIGHTS_0 and uint32 indices. An empty mesh becomes one degenerate
        triangle (glTF needs POSITION)."""
        buf = self.buffer
        attrs: dict[str, int] = {}
        f = np.asarray(faces)
        prim: dict[str, Any] = {"attributes": attrs, "mode": 4}
        if not len(f):
            attrs["POSITION"] = buf.add(np.zeros((3, 3), np.float32), "VEC3", target=ARRAY_BUFFER, minmax=True)
        else:
            attrs["POSITION"] = buf.add(np.asarray(vertices, np.float32), "VEC3", target=ARRAY_BUFFER, minmax=True)
            for key, arr, atype, dtype, norm in (("NORMAL", normals, "VEC3", np.float32, False),
                                                 ("TEXCOORD_0", uv, "VEC2", np.float32, False),
                                                 ("COLOR_0", colors, None, np.uint8, True),
                                                 ("JOINTS_0", joints, "VEC4", None, False),
                                                 ("WEIGHTS_0", weights, "VEC4", np.float32, False)):
                if arr is None:
                    continue
                a = np.asarray(arr) if dtype is None else np.asarray(arr, dtype)
                attrs[key] = buf.add(a, atype or f"VEC{a.shape[1]}", target=ARRAY_BUFFER, normalized=norm)
            prim["indices"] = buf.add(f.astype(np.uint32).ravel(), "SCALAR", target=ELEMENT_ARRAY_BUFFER)
        if material is not None:
            prim["material"] = int(material)
        return prim

    def add_mesh(self, name: str, primitives: list[dict[str, Any]]) -> int:
        self.meshes.append({"name": name, "primitives": list(primitives)})
        return len(self.meshes) - 1

    def add_node(self, **fields) -> int:
        """A node; ``fields`` are glTF node properties (``name``, ``mesh``, ``skin``, ``children``,
        ``translation``, ``rotation``, ``scale``); None values are left out."""
        self.nodes.append({k: v for k, v in fields.items() if v is not None})
        return len(self.nodes) - 1

    def add_scene(self, nodes: list[int], name: str | None = None) -> int:
        self.scenes.append({"nodes": list(nodes), **({"name": name} if name is not None else {})})
        return len(self.scenes) - 1

    def document(self, uri: str | None = None) -> dict[str, Any]:
        """The JSON document; ``uri`` names the external buffer of a ``.gltf``."""
        blob_len = len(self.buffer.blob())
        doc: dict[str, Any] = {"asset": self.asset}
        if self.scenes:
            doc["scene"] = 0
        for key in ("scenes", "nodes", "meshes", "materials", "textures", "images", "samplers", "skins",
                    "animations"):
            if getattr(self, key):
                doc[key] = getattr(self, key)
        doc["accessors"] = self.buffer.accessors
        doc["bufferViews"] = self.buffer.views
        doc["buffers"] = [{"byteLength": blob_len, **({"uri": uri} if uri is not None else {})}]
        return doc

    def glb(self) -> bytes:
        """The binary glTF container: header, JSON chunk (space padded), BIN chunk (zero padded)."""
        blob = self.buffer.blob()
        js = json.dumps(self.document(), separators=(",", ":")).encode()
        js += b" " * ((-len(js)) % 4)
        total = 12 + 8 + len(js) + 8 + len(blob)
        return (struct.pack("<4sII", b"glTF", 2, total) + struct.pack("<I4s", len(js), b"JSON") + js
                + struct.pack("<I4s", len(blob), b"BIN\0") + blob)

    def write(self, path, *, binary: bool | None = None) -> Path:
        """Write ``.glb`` (one file) or ``.gltf`` (JSON and ``<stem>.bin`` beside it, the JSON renamed last),
        atomically, through the writer registry; ``binary`` None picks by the suffix."""
        return save_with(emit_gltf, path, self, binary=_binary(path, binary))


def _binary(path, binary: bool | None) -> bool:
    """``binary`` as given, else by ``path``'s suffix: ``.glb`` one binary file, ``.gltf`` JSON and its ``.bin``."""
    return format_of(path, {".gltf": "gltf", ".glb": "glb"}) == "glb" if binary is None else bool(binary)


def emit_gltf(res, name: str, parts, *, binary: bool, generator: str = "PlantVR", **_other) -> None:
    """The glTF emitter of the writer registry (rows ``glb`` and ``gltf``): a :class:`Gltf` document, or
    ``parts`` (one glTF mesh and node per part, see :func:`parts_document`), as ``name`` in ``res``'s folder:
    one ``.glb``, or the ``.gltf`` JSON and its buffer ``<stem>.bin``."""
    g = parts if isinstance(parts, Gltf) else parts_document(parts, generator=generator)
    if binary:
        res.write(name, g.glb())
    else:
        stem = Path(name).stem
        blob = g.buffer.blob()
        res.write(f"{stem}.bin", blob)
        res.write(name, json.dumps(g.document(uri=f"{stem}.bin"), separators=(",", ":")))


def parts_document(parts, *, generator: str = "PlantVR") -> Gltf:
    """The glTF document of a list of :class:`plantvr.io.writers.Part`: one mesh and one root node per part.

    Each primitive has float32 POSITION, NORMAL and TEXCOORD_0 (``1 - v``: glTF's origin is the image's top
    left) when the part has them, and COLOR_0 for vertex colours of an untextured part. A textured part gets a
    material named after it with the image (PNG, embedded) as base colour texture; a part with vertex colours
    and no material options gets none; any other part a material ``material.get("name", "material_<k>")``
    (white unless ``rgba``). Material options: ``rgba``, ``metallic`` (0), ``roughness`` (0.9),
    ``double_sided``, ``alpha_mode`` (``"OPAQUE"`` when textured), ``alpha_cutoff``.
    """
    parts = as_parts(parts)
    checked = []
    for k, p in enumerate(parts):                 # everything checked before the document is built
        label = "mesh" if len(parts) == 1 else f"parts[{k}]"
        v, f = _check_mesh(label, (p.vertices, p.faces))
        img = None if p.image is None else check_image(f"{label} image", p.image)
        colors = None
        if p.colors is not None and img is None:
            colors = np.asarray(p.colors)
            if colors.dtype != np.uint8 or colors.shape not in ((len(v), 3), (len(v), 4)):
                raise ValueError(f"colors must be uint8 of shape ({len(v)}, 3) or ({len(v)}, 4), "
                                 f"got {colors.dtype} {colors.shape}")
        nrm = None if p.normals is None else check_array(f"{label} normals" if len(parts) > 1 else "normals",
                                                         p.normals, shape=(len(v), 3))
        uv = None if p.uv is None else check_array(f"{label} uv", p.uv, shape=(len(v), 2), max_abs=MAX_GLB_COORD)
        if not isinstance(p.material, dict):
            raise ValueError(f"{label} material must be a dict, got {type(p.material).__name__}")
        checked.append((v, f, img, colors, nrm, uv))
    g = Gltf(generator)
    roots = []
    for k, (p, (v, f, img, colors, nrm, uv)) in enumerate(zip(parts, checked)):
        o = p.material
        mat = None
        if img is not None or colors is None or o:
            rgba = o.get("rgba", None if img is not None else (1.0, 1.0, 1.0, 1.0))
            mat = g.add_material(o.get("name", p.name if img is not None else f"material_{k}"), rgba=rgba,
                                 texture=img, metallic=o.get("metallic", 0.0), roughness=o.get("roughness", 0.9),
                                 double_sided=o.get("double_sided", False),
                                 alpha_mode=o.get("alpha_mode", "OPAQUE" if img is not None else None),
                                 alpha_cutoff=o.get("alpha_cutoff"))
        gl_uv = None if uv is None else np.column_stack([uv[:, 0], 1.0 - uv[:, 1]])
        mesh = g.add_mesh(p.name, [g.primitive(v, f, normals=nrm, uv=gl_uv, colors=colors, material=mat)])
        roots.append(g.add_node(name=p.name, mesh=mesh))
    g.add_scene(roots)
    return g


def write_mesh(path, vertices, faces, *, colors=None, normals=None, name: str = "mesh",
               binary: bool | None = None) -> Path:
    """One mesh, one node, as ``.glb`` or ``.gltf``: positions, optional (V, 3|4) uint8 vertex colours
    (COLOR_0) and normals; vertex order kept (label meshes, segmentations, subdivision surfaces)."""
    return save_with(emit_gltf, path, Part(name, vertices, faces, normals=normals, colors=colors),
                     binary=_binary(path, binary))


def write_textured(path, parts: list[dict[str, Any]]) -> Path:
    """Textured meshes as ``.glb``: one glTF mesh and node per part.

    Parameters
    ----------
    path : str or pathlib.Path
        Output ``.glb``.
    parts : list of dict
        ``{"name": str, "vertices": (V, 3), "faces": (F, 3), "uv": (V, 2) (OpenGL convention, v up; written
        as glTF's ``1 - v``), "image": (H, W, 3|4) uint8, "normals": (V, 3) optional, "double_sided": bool,
        "alpha_mode": "OPAQUE" | "MASK", "alpha_cutoff": float, "roughness": float}``.

    Returns
    -------
    pathlib.Path
    """
    path = check_glb_path(path)
    opts = ("roughness", "double_sided", "alpha_mode", "alpha_cutoff")
    return save_with(emit_gltf, path, [Part(p["name"], p["vertices"], p["faces"], normals=p.get("normals"), uv=p["uv"],
                            image=p["image"], material={k: p[k] for k in opts if p.get(k) is not None})
                       for p in parts], binary=True)


def _check_mesh(name: str, mesh) -> tuple[np.ndarray, np.ndarray]:
    if isinstance(mesh, (str, bytes, dict)) or not hasattr(mesh, "__len__") or len(mesh) != 2:
        raise ValueError(f"{name} must be (vertices, faces), got {type(mesh).__name__}")
    v, f = mesh
    v = check_array(f"{name} vertices", v, shape=(None, 3), max_abs=MAX_GLB_COORD)
    if len(v) >= 2 ** 32 or len(v) > MAX_COUNT:
        raise ValueError(f"{name} vertices must be fewer than {MAX_COUNT}, got {len(v)}")
    try:
        f = np.asarray(f)
    except (TypeError, ValueError):
        raise ValueError(f"{name} faces must be an (F, 3) int array, got {type(f).__name__}") from None
    if f.size == 0:
        f = np.zeros((0, 3), np.int64)
    if f.ndim != 2 or f.shape[1] != 3 or f.dtype.kind not in "iu" or len(f) > MAX_COUNT or \
            (len(f) and (f.min() < 0 or f.max() >= len(v))):
        raise ValueError(f"{name} faces must be (F, 3) integer indices into its {len(v)} vertices, got "
                         f"{f.dtype} {f.shape}")
    return v, f.astype(np.int64)


def _check_rgba(name: str, c) -> tuple[float, ...]:
    rgba = check_array(name, c, shape=(4,))
    if np.any(rgba < 0) or np.any(rgba > 1):
        raise ValueError(f"{name} must be RGBA values in [0, 1], got {rgba.tolist()}")
    return tuple(float(x) for x in rgba)


def _vertex_normals(v: np.ndarray, f: np.ndarray) -> np.ndarray:
    """Area-weighted vertex normals (unit; +y where a vertex has no face)."""
    n = np.zeros_like(v)
    if len(f):
        fn = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
        for k in range(3):
            np.add.at(n, f[:, k], fn)
    ln = np.linalg.norm(n, axis=1)
    out = np.tile([0.0, 1.0, 0.0], (len(v), 1))
    ok = ln > 0
    out[ok] = n[ok] / ln[ok, None]
    return out


def write_glb(path, meshes: list[dict[str, Any]], nodes: list[dict[str, Any]], *,
              generator: str = "PlantVR landscape", scene_name: str = "landscape") -> Path:
    """Write meshes and the nodes that place them (instancing: nodes share meshes) as one binary glTF file.

    Parameters
    ----------
    path : str or pathlib.Path
        Output file, ``.glb``.
    meshes : list of dict
        ``{"vertices": (V, 3) float, "faces": (F, 3) int, "name": str, "color": (4,) RGBA in [0, 1],
        "double_sided": bool}``, or ``{"name": str, "parts": [such dicts]}`` for a mesh of several primitives
        (e.g. bark and leaves); one glTF mesh each, with float32 positions, vertex normals and uint32 indices,
        and one material per distinct colour.
    nodes : list of dict
        ``{"mesh": int, "name": str, "translation": (3,), "rotation": (4,) quaternion (x, y, z, w),
        "scale": (3,)}`` (transform entries optional); all are roots of the one scene.
    generator, scene_name : str
        ``asset.generator`` and the scene's name.

    Returns
    -------
    pathlib.Path
    """
    path = check_glb_path(path)
    if not isinstance(meshes, (list, tuple)) or not all(isinstance(m, dict) for m in meshes):
        raise ValueError("meshes must be a list of dicts")
    if not isinstance(nodes, (list, tuple)) or not all(isinstance(nd, dict) for nd in nodes):
        raise ValueError("nodes must be a list of dicts")
    for k, nd in enumerate(nodes):
        m = nd.get("mesh")
        if isinstance(m, (bool, np.bool_)) or not isinstance(m, (int, np.integer)) or not 0 <= m < len(meshes):
            raise ValueError(f"nodes[{k}] mesh must be an index in [0, {len(meshes)}), got {m!r}")
        if not isinstance(nd.get("name", ""), str):
            raise ValueError(f"nodes[{k}] name must be a str, got {nd.get('name')!r}")
    parts = []
    for i, m in enumerate(meshes):
        ps = m.get("parts", [m])
        if not isinstance(ps, (list, tuple)) or not ps or not all(isinstance(q, dict) for q in ps):
            raise ValueError(f"meshes[{i}] parts must be a non-empty list of dicts")
        if not isinstance(m.get("name", ""), str):
            raise ValueError(f"meshes[{i}] name must be a str, got {m.get('name')!r}")
        for j, q in enumerate(ps):
            if "vertices" not in q or "faces" not in q:
                raise ValueError(f"meshes[{i}] part {j} must have vertices and faces")
            _check_rgba(f"meshes[{i}] part {j} color", q.get("color", _DEFAULT_RGBA))
        parts.append(ps)
    checked = [[_check_mesh(f"meshes[{i}] part {j}", (q["vertices"], q["faces"])) for j, q in enumerate(ps)]
               for i, ps in enumerate(parts)]
    transforms = []
    for k, nd in enumerate(nodes):  # every transform checked before anything is written
        transforms.append({key: check_array(f"nodes[{k}] {key}", nd[key], shape=(n,), max_abs=MAX_GLB_COORD).tolist()
                           for key, n in (("translation", 3), ("rotation", 4), ("scale", 3))
                           if nd.get(key) is not None})
    g = Gltf(generator)
    mat_index: dict[tuple, int] = {}
    for i, (cm, ps, m) in enumerate(zip(checked, parts, meshes)):
        prims = []
        for (v, f), q in zip(cm, ps):
            rgba = tuple(float(c) for c in q.get("color", _DEFAULT_RGBA))
            key = (rgba, bool(q.get("double_sided", False)))
            if key not in mat_index:  # one material per colour, shared by the meshes
                mat_index[key] = g.add_material(f"material_{len(mat_index)}", rgba=rgba, double_sided=key[1])
            prims.append(g.primitive(v, f, normals=_vertex_normals(v, f) if len(f) else None,
                                     material=mat_index[key]))
        g.add_mesh(m.get("name", f"mesh_{i}"), prims)
    for k, nd in enumerate(nodes):
        g.add_node(name=nd.get("name", f"node_{k}"), mesh=int(nd["mesh"]), **transforms[k])
    g.add_scene(list(range(len(nodes))), name=scene_name)
    return g.write(path)

