"""``plantvr demo`` writes a mesh, a picture and a tree file from the built-in strokes."""
import trimesh

from plantvr.cli import main


def test_demo_writes_mesh_png_and_tree(tmp_path, capsys):
    assert main(["demo", "--out", str(tmp_path), "--steps", "25", "--seed", "1"]) == 0
    out = capsys.readouterr().out
    assert "internodes" in out and "ms/step" in out
    mesh = trimesh.load(tmp_path / "tree.ply", process=False)
    assert len(mesh.faces) > 100
    assert (tmp_path / "tree.glb").stat().st_size > 1000
    assert (tmp_path / "tree.png").read_bytes()[:4] == b"\x89PNG"
    assert (tmp_path / "tree.tree").read_text().startswith("# plantvr-tree")


def test_demo_rejects_bad_steps(capsys):
    import pytest
    with pytest.raises(SystemExit):
        main(["demo", "--steps", "0"])
    assert "--steps must be >= 1" in capsys.readouterr().err


def test_export_subcommand_round_trip(tmp_path):
    main(["demo", "--out", str(tmp_path), "--steps", "10", "--seed", "2"])
    assert main(["export", str(tmp_path / "tree.tree"), "--format", "obj", "-o", str(tmp_path / "t.obj")]) == 0
    assert trimesh.load(tmp_path / "t.obj", force="mesh").faces.shape[0] > 50


def test_segment_subcommand_headless(tmp_path):
    assert main(["segment", "synth", "--out", str(tmp_path), "--stamps", "3"]) == 0
    assert trimesh.load(tmp_path / "segment.ply", process=False).faces.shape[0] > 100


def test_params_reference_lists_every_row_of_every_document_table(capsys):
    from plantvr import documents
    from plantvr.cli import main
    from plantvr.document import Document

    assert main(["params"]) == 0
    page = capsys.readouterr().out
    tables = [c.PARAMS for c in (getattr(documents, n) for n in documents.__all__)
              if isinstance(c, type) and issubclass(c, Document) and c.PARAMS is not None]
    assert len(tables) >= 3
    for table in tables:
        assert f"## {table.name} parameters" in page
        for p in table:
            assert f"| `{p.name}` |" in page
    assert main(["params", "nope"]) == 2
