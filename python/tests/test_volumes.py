"""Volumes as numpy arrays and containers: round trips are exact."""
import numpy as np
import pytest
import tetlod


def test_sample_volume_is_an_array_indexed_zyx():
    a = tetlod.sample_volume("sphere", (5, 6, 7), "u16")
    assert a.shape == (7, 6, 5)
    assert a.dtype == np.uint16


def test_volume_file_round_trip(volume, work):
    path, array = volume
    back = tetlod.read_volume(path)
    assert back.dtype == np.uint8 and back.shape == (17, 17, 17)
    np.testing.assert_array_equal(back, array)
    floats = (array.astype(np.float32) / 7.0)
    raw = str(work / "floats.raw")
    tetlod.write_volume(floats, raw)
    np.testing.assert_array_equal(tetlod.read_volume(raw, dims=(17, 17, 17), dtype="f32"), floats)


def test_container_info_and_decode(container, volume):
    info = tetlod.info(container)
    assert info["models"] == ["ht", "mt"]
    assert info["dims"] == (17, 17, 17)
    assert info["dtype"] == "u8"
    assert info["range"][0] <= info["range"][1]
    assert tetlod.models(container) == ["ht", "mt"]
    assert tetlod.is_container(container)
    np.testing.assert_array_equal(tetlod.decode(container), volume[1])


def test_missing_file_raises_tetlod_error_naming_it(work):
    missing = str(work / "no_such_volume.nrrd")
    with pytest.raises(tetlod.Error) as caught:
        tetlod.read_volume(missing)
    assert "no_such_volume.nrrd" in str(caught.value)
    assert isinstance(caught.value, RuntimeError)
    assert caught.value.code in ("IoError", "NotFound")


def test_corrupt_container_raises_tetlod_error_naming_it(container, work):
    data = open(container, "rb").read()
    broken = work / "broken.tlod"
    broken.write_bytes(data[: len(data) // 3])
    for call in (tetlod.info, tetlod.decode, lambda p: tetlod.extract(p, error=0)):
        with pytest.raises(tetlod.Error) as caught:
            call(str(broken))
        assert "broken.tlod" in str(caught.value)
        assert caught.value.code in ("Truncated", "CorruptData", "ChecksumMismatch", "SizeMismatch")


def test_bad_arguments_raise_tetlod_error(volume):
    with pytest.raises(tetlod.Error, match="dtype"):
        tetlod.read_volume(volume[0], dtype="u7")
    with pytest.raises(tetlod.Error, match="unknown keyword 'dimz'"):
        tetlod.read_volume(volume[0], dimz=(1, 2, 3))
    with pytest.raises(tetlod.Error, match="model 'xt'"):
        tetlod.open(volume[0], model="xt")
