"""Meshes as numpy arrays: shapes, valid indices, no copies, and the same mesh
the command line writes."""
import filecmp
import gc
import threading

import numpy as np
import pytest
import tetlod


def check_mesh(mesh):
    n, m = mesh.vertex_count, mesh.tet_count
    assert m > 0
    assert mesh.points.shape == (n, 3) and mesh.points.dtype == np.int32
    assert mesh.tets.shape == (m, 4) and mesh.tets.dtype == np.uint32
    assert mesh.values.shape == (n,) and mesh.values.dtype == np.float64
    assert mesh.error.shape == (m,) and mesh.error.dtype == np.float32
    assert mesh.level.shape == (m,)
    assert int(mesh.tets.max()) < n
    assert len(np.unique(mesh.tets)) == n  # every vertex is used
    assert mesh.world_points().shape == (n, 3)


@pytest.mark.parametrize("model", ["ht", "mt"])
def test_extract_from_container(container, model):
    mesh = tetlod.extract(container, model=model, error="5%")
    check_mesh(mesh)
    assert mesh.model == model.upper()
    lo, hi = mesh.range
    assert float(mesh.error.max()) <= 0.05 * (hi - lo) + 1e-6
    full = tetlod.extract(container, model=model, full=True)
    assert full.tet_count >= mesh.tet_count


@pytest.mark.parametrize("model", ["ht", "mt"])
def test_extract_from_volume_matches_container(volume, container, model):
    a = tetlod.extract(volume[0], model=model, error=3.0)
    b = tetlod.extract(container, model=model, error=3.0)
    check_mesh(a)
    np.testing.assert_array_equal(a.points, b.points)
    np.testing.assert_array_equal(a.tets, b.tets)
    np.testing.assert_array_equal(a.values, b.values)


def test_region_queries(container):
    box = tetlod.extract(container, error=-1, error_out="inf", box=(0, 0, 0, 4, 4, 4))
    check_mesh(box)
    iso = tetlod.extract(container, error=0, isovalues=[100.0])
    check_mesh(iso)
    with pytest.raises(tetlod.Error, match="error="):
        tetlod.extract(container)


@pytest.mark.parametrize("model", ["ht", "mt"])
def test_sphere_region(container, model):
    assert "sphere" in tetlod.query_regions()
    coarse = tetlod.extract(container, model=model, error="inf")
    ball = tetlod.extract(container, model=model, error=0, regions={"sphere": (8, 8, 8, 4)})
    check_mesh(ball)
    assert ball.tet_count > coarse.tet_count
    # the same region as text, and through a model in memory
    text = tetlod.extract(container, model=model, error=0, regions={"sphere": "8,8,8,4"})
    assert np.array_equal(text.tets, ball.tets)
    held = tetlod.open(container, model=model).extract(error=0, regions={"sphere": [8, 8, 8, 4]})
    assert np.array_equal(held.tets, ball.tets) and np.array_equal(held.points, ball.points)
    # a tet with a corner in the ball meets it, so it honours error 0
    corners = ball.points[ball.tets].astype(np.float64)
    near = (np.linalg.norm(corners - np.array([8.0, 8.0, 8.0]), axis=2) <= 4).any(axis=1)
    assert near.sum() > 0 and float(ball.error[near].max()) == 0.0
    with pytest.raises(tetlod.Error, match="no query region 'cube'"):
        tetlod.extract(container, model=model, error=0, regions={"cube": "1"})
    with pytest.raises(tetlod.Error, match="radius is negative"):
        tetlod.extract(container, model=model, error=0, regions={"sphere": (1, 2, 3, -1)})
    with pytest.raises(tetlod.Error, match="expected a dict"):
        tetlod.extract(container, model=model, error=0, regions=[("sphere", "1,2,3,4")])


def test_arrays_are_views_that_keep_the_mesh_alive(container):
    mesh = tetlod.extract(container, error="2%")
    first, second = mesh.points, mesh.points
    assert np.shares_memory(first, second)  # no copy per access
    assert not first.flags.writeable
    expected = np.array(mesh.tets)
    tets = mesh.tets
    del mesh, first, second
    gc.collect()
    np.testing.assert_array_equal(tets, expected)


def test_extract_equals_the_cli_output(container, cli, work):
    cli_out = str(work / "cli.vtu")
    cli("extract", container, cli_out, "--error", "1%")
    mesh = tetlod.extract(container, error="1%")
    py_out = str(work / "py.vtu")
    mesh.write(py_out)
    assert filecmp.cmp(cli_out, py_out, shallow=False)
    meshio = pytest.importorskip("meshio")
    back = meshio.read(cli_out)
    np.testing.assert_allclose(back.points, mesh.world_points())
    np.testing.assert_array_equal(back.cells_dict["tetra"], mesh.tets)


def test_write_mesh_formats(container, work):
    mesh = tetlod.extract(container, error="5%")
    for ext in ("vtk", "msh", "mesh"):
        path = work / f"m.{ext}"
        tetlod.write_mesh(mesh, str(path))
        assert path.stat().st_size > 0
    with pytest.raises(tetlod.Error, match="m.xyz"):
        mesh.write(str(work / "m.xyz"))


def test_isosurface(container):
    surface = tetlod.isosurface(container, [64.0, 160.0])
    k = len(surface.triangles)
    assert k > 0
    assert surface.triangles.shape == (k, 3)
    assert surface.points.shape[1] == 3 and np.isfinite(surface.points).all()
    assert int(surface.triangles.max()) < len(surface.points)
    assert set(np.unique(surface.face_surface)) <= {0, 1}


def test_model_and_stats(volume):
    model = tetlod.open(volume[0], model="mt")
    assert model.kind == "MT" and model.dims == (17, 17, 17)
    check_mesh(model.extract(error="2%"))
    stats = model.stats(error_fractions=[0.01, 0.1])
    assert isinstance(stats, dict)
    assert "MT" in str(stats)


def test_concurrent_extracts_release_the_gil(container):
    model = tetlod.open(container)
    results = [None] * 4

    def work(i):
        results[i] = model.extract(error=f"{i + 1}%").tet_count

    threads = [threading.Thread(target=work, args=(i,)) for i in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert results == [model.extract(error=f"{i + 1}%").tet_count for i in range(4)]


def test_mt_only_container_defaults_to_the_mt(volume, work):
    path = str(work / "mt_only.tlod")
    summary = tetlod.convert(volume[0], path, ht=False, mt=True)
    assert summary["mt_updates"] > 0
    assert tetlod.models(path) == ["mt"]
    assert tetlod.open(path).kind == "MT"
    assert tetlod.extract(path, error="2%").model == "MT"
    with pytest.raises(tetlod.Error, match="mt_only.tlod"):
        tetlod.extract(path, model="ht", error=0)


def test_convert_takes_a_zstd_level_or_none(volume, work, monkeypatch):
    # None (the default): the library's levels; a number: the level of every frame.
    # One creation time for the three files: the compressed METADATA holds it, and
    # two converts on either side of a second could differ by a byte (CI, session 27).
    monkeypatch.setenv("SOURCE_DATE_EPOCH", "0")
    default = tetlod.convert(volume[0], str(work / "level_default.tlod"), mt=True)
    fast = tetlod.convert(volume[0], str(work / "level_1.tlod"), mt=True, zstd_level=1)
    explicit = tetlod.convert(volume[0], str(work / "level_19.tlod"), mt=True, zstd_level=19)
    assert fast["bytes"] > default["bytes"]
    assert explicit["bytes"] == default["bytes"]  # no stream of this volume is above 1 MiB
    with pytest.raises(tetlod.Error):
        tetlod.convert(volume[0], str(work / "level_23.tlod"), zstd_level=23)


def test_convert_fast_decode_writes_static_chunks_that_decode_exactly(volume, work):
    # fast_decode: the field in static-table chunks (format 3.7), the same samples back;
    # with an MT-only container there is no HT field to code that way: refused. (On the
    # Marschner-Lobb fixture zstd of the samples wins every chunk: nothing static.)
    source = str(work / "fast_ms.nrrd")
    tetlod.write_volume(tetlod.sample_volume("multiscale", (33, 33, 33), "u16"), source)
    path, default = str(work / "fast_decode.tlod"), str(work / "fast_default.tlod")
    tetlod.convert(source, path, fast_decode=True)
    tetlod.convert(source, default)
    # 3.7, or 3.8 with a range-exp error chunk; only the fast one has static field chunks.
    def coders(p, kind):
        return {c["coder"] for c in tetlod.info(p)["coders"] if c["type"] == kind}
    for p, without_exp in ((path, ("3.7",)), (default, ("3.2", "3.6"))):
        version = tetlod.info(p)["format_version"]
        assert version == "3.8" if "ht-range-exp" in coders(p, "HT_ERRORS") else version in without_exp
    assert "ht-static-rans" in coders(path, "HT_FIELD")
    assert "ht-static-rans" not in coders(default, "HT_FIELD")
    assert (tetlod.decode(path) == tetlod.decode(default)).all()
    with pytest.raises(tetlod.Error, match="no HT"):
        tetlod.convert(volume[0], str(work / "fast_mt.tlod"), ht=False, mt=True, fast_decode=True)


def test_convert_takes_the_brick_size_and_error_bits(volume, work):
    # None: the library's automatic bricks (5 for a volume this small) and 4
    # error bits; given, they are what the file says, as the CLI's options.
    auto = str(work / "bricks_auto.tlod")
    tetlod.convert(volume[0], auto)
    assert tetlod.info(auto)["ht"]["brick_log2"] == 5
    fine = str(work / "bricks_2.tlod")
    tetlod.convert(volume[0], fine, brick_log2=2, error_bits=0)
    info = tetlod.info(fine)
    assert info["ht"]["brick_log2"] == 2
    assert info["ht"]["error_mantissa_bits"] == 0
    assert (tetlod.decode(fine) == tetlod.decode(auto)).all()
    with pytest.raises(tetlod.Error, match="brick_log2"):
        tetlod.convert(volume[0], str(work / "bricks_17.tlod"), brick_log2=17)
    with pytest.raises(tetlod.Error, match="error bits"):
        tetlod.convert(volume[0], str(work / "bits_8.tlod"), error_bits=8)


def test_lossy_container_states_its_bound_on_every_tet(volume, cli, work):
    # A lossy container (every sample within E = 3 of the original): no tet's
    # bound is below E, the finest (unit) tets included.
    path = str(work / "lossy.tlod")
    cli("convert", volume[0], path, "--max-error", "3")
    finest = tetlod.extract(path, error=0)
    assert finest.field_max_error == 3.0
    assert float(finest.error.min()) >= 3.0
    assert finest.max_error >= 3.0
    # Below E nothing is coarse enough: the finest mesh, as full=True gives it.
    assert finest.tet_count == tetlod.extract(path, full=True).tet_count
    assert tetlod.open(path).field_max_error == 3.0


def test_lossless_container_has_no_field_error(container):
    assert tetlod.extract(container, error=0).field_max_error == 0.0
    assert tetlod.open(container).field_max_error == 0.0


def test_convert_lossy_with_both_models(volume, work):
    # max_error: a bound in field units or a percentage of the range; the MT
    # beside a lossy HT states its bounds against the original too (format 3.5).
    path = str(work / "lossy_both.tlod")
    summary = tetlod.convert(volume[0], path, mt=True, max_error="2%")
    assert summary["max_error"] == 5.0  # 2% of 0..255, an integer field states floor(5.1)
    # 3.5 (LOSSY_MT), or 3.6, which includes it, when a field chunk is range-2d,
    # or 3.8 when an error chunk is range-exp (info's coders say which)
    info = tetlod.info(path)
    coders = {c["coder"] for c in info["coders"]}
    expected = "3.8" if "ht-range-exp" in coders else "3.6" if "ht-range-2d" in coders else "3.5"
    assert info["format_version"] == expected
    for model in ("ht", "mt"):
        assert tetlod.open(path, model=model).field_max_error == 5.0
        mesh = tetlod.extract(path, model=model, error="5%")
        assert mesh.field_max_error == 5.0
        assert float(mesh.error.min()) >= 0.0
        assert mesh.max_error <= 0.05 * 255 + 1e-6
        finest = tetlod.extract(path, model=model, error=0)
        assert float(finest.error.min()) >= 5.0
    assert tetlod.convert(volume[0], str(work / "lossless.tlod"), max_error=None)["max_error"] == 0.0
    for bad in (-1, "inf", "x%"):
        with pytest.raises(tetlod.Error):
            tetlod.convert(volume[0], str(work / "bad.tlod"), max_error=bad)
    with pytest.raises(tetlod.Error, match="MT alone"):
        tetlod.convert(volume[0], str(work / "bad.tlod"), ht=False, mt=True, max_error=3)


def test_convert_streams_the_ht_within_a_memory_budget(work, monkeypatch):
    # A file format that reads planes is converted plane by plane (the HT
    # alone): memory_bytes is the budget it plans for, the bytes are those of
    # the default conversion, and a budget too small to stream is refused.
    monkeypatch.setenv("SOURCE_DATE_EPOCH", "0")
    array = tetlod.sample_volume("multiscale", (33, 31, 29), "u16")
    source = str(work / "ms_u16.nrrd")
    tetlod.write_volume(array, source)
    default = str(work / "stream_default.tlod")
    budget = str(work / "stream_64mib.tlod")
    tetlod.convert(source, default)
    assert tetlod.convert(source, budget, memory_bytes=64 << 20)["bytes"] > 0
    with open(default, "rb") as a, open(budget, "rb") as b:
        assert a.read() == b.read()
    assert np.array_equal(tetlod.decode(budget), np.array(array))
    with pytest.raises(tetlod.Error, match="plane by plane"):
        tetlod.convert(source, str(work / "stream_tiny.tlod"), memory_bytes=4096)
    with pytest.raises(tetlod.Error, match="memory_bytes"):
        tetlod.convert(source, str(work / "stream_zero.tlod"), memory_bytes=0)
    # "1%" from planes: the original's range, read before the conversion.
    lossy = str(work / "stream_lossy.tlod")
    original = np.array(array).astype(np.int64)
    bound = np.floor((original.max() - original.min()) / 100)
    assert tetlod.convert(source, lossy, max_error="1%", memory_bytes=64 << 20)["max_error"] == bound
    assert np.abs(tetlod.decode(lossy).astype(np.int64) - original).max() <= bound


def test_verify_reports_each_check_and_the_first_problem(work):
    # tetlod.verify is `tetlod verify` as a report: a sound file passes every
    # stage (deep: every stored bound recomputed), a damaged one names the
    # file and its problem, a missing one too; neither raises.
    array = tetlod.sample_volume("multiscale", (13, 11, 9), "u8")
    source = str(work / "verify_src.nrrd")
    tetlod.write_volume(array, source)
    both = str(work / "verify_both.tlod")
    tetlod.convert(source, both, ht=True, mt=True)
    shallow = tetlod.verify(both)
    assert shallow["ok"] and shallow["failure"] is None and not shallow["deep"]
    assert shallow["checksums_ok"] and shallow["models"] == ["ht", "mt"]
    assert shallow["mt"]["ok"] and shallow["mt"]["updates"] > 0 and "deep_ok" not in shallow["mt"]
    assert shallow["ht"]["ok"] and "deep_ok" not in shallow["ht"]
    deep = tetlod.verify(both, deep=True)
    assert deep["ok"] and deep["deep"]
    assert deep["mt"]["deep_ok"] and deep["mt"]["bounds_checked"] > deep["mt"]["updates"]
    assert deep["mt"]["worst_bound_ratio"] >= 1
    assert deep["ht"]["deep_ok"] and deep["ht"]["bounds_checked"] > 0
    # Lossy: the report states E, and the deep checks hold against it.
    lossy = str(work / "verify_lossy.tlod")
    tetlod.convert(source, lossy, ht=True, mt=True, max_error=3)
    report = tetlod.verify(lossy, deep=True)
    assert report["ok"] and report["max_error"] == 3 and report["mt"]["deep_ok"]
    # One byte flipped in the middle of the file: a checksum names it.
    with open(both, "rb") as f:
        data = bytearray(f.read())
    data[len(data) // 2] ^= 0x40
    damaged = str(work / "verify_damaged.tlod")
    with open(damaged, "wb") as f:
        f.write(bytes(data))
    bad = tetlod.verify(damaged, deep=True)
    assert not bad["ok"] and not bad["checksums_ok"]
    assert bad["failure"]["code"] and "verify_damaged.tlod" in bad["failure"]["message"]
    missing = tetlod.verify(str(work / "no_such.tlod"))
    assert not missing["ok"] and "no_such.tlod" in missing["failure"]["message"]
