"""The io layer: one writer per format, behind one registry, and every exporter (issues 21, 30).

=================  ======================================================================================
module             writes
=================  ======================================================================================
``io.ply``         :func:`write_ply`: the one PLY writer (binary, colours, labels, normals)
``io.obj``         :func:`write_obj`, :func:`write_obj_sequence`: the one OBJ writer (UVs, normals,
                   vertex colours, materials with textures, frame sequences)
``io.gltf``        :class:`Gltf`, :func:`write_glb`, :func:`write_mesh`, :func:`write_textured`: the one glTF
                   writer (meshes, materials and textures, skins, animations, instancing by shared meshes)
``io.usd``         :func:`plantvr.io.usd.export_usd`: the one USD writer (point-instanced leaves)
``io.tree``        tree→mesh entry points and the tree exporters (PLY/OBJ/glTF, skinned glTF, USD, LOD)
``io.landscape``   landscapes, forests and species libraries as one instanced glTF scene
``io.labels``      segmentations and per-label meshes, the label table
``io.mesh``        :func:`plantvr.io.mesh.export_mesh`: any triangle mesh by suffix
``io.scene``       :func:`plantvr.io.scene.export_scene`: any document's scene (trees, coloured shapes)
``io.writers``     the writer registry: format → its one emitter, :func:`~plantvr.io.writers.save`
``io.parts``       what a save writes (:class:`~plantvr.io.parts.Part`) and the atomic resolver of its files
=================  ======================================================================================

The io layer sits above the documents and the numeric cores and below the views: nothing here imports
``plantvr.view``, ``plantvr.ui`` or ``plantvr.vr``; the cores never import it.
"""
from __future__ import annotations

from .gltf import Gltf, write_glb, write_mesh, write_textured
from .obj import write_obj, write_obj_sequence
from .ply import write_ply

__all__ = ["Gltf", "write_glb", "write_mesh", "write_obj", "write_obj_sequence", "write_ply", "write_textured"]
