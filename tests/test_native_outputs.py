"""mi.render with masked_path, written by Mitsuba's own writers: the EXR's layers carry their names."""
import numpy as np
import pytest

from conftest import STILL_LIFE
from gmcpt.errors import GmcptError


@pytest.fixture(scope="module")
def rendered(mi):
    """The still life at 32x32 through mi.render: (scene, the returned tensor as an array)."""
    scene = mi.load_file(str(STILL_LIFE), res=32, spp=4, rate=0.25)
    return scene, np.asarray(mi.render(scene))


def test_film_bitmap_written_by_mitsuba_has_named_layers(mi, rendered, tmp_path):
    from gmcpt.io.exr import channel_names, named_channels, read_exr, unpack

    scene, tensor = rendered
    film = scene.sensors()[0].film()
    bitmap = film.bitmap()  # raised "No storage allocated" when the plugin left the film untouched
    assert [field.name for field in bitmap.struct_()] == channel_names()
    assert np.array_equal(np.asarray(bitmap), tensor)
    assert np.array_equal(np.asarray(film.develop()), tensor)
    path = tmp_path / "still-life.exr"
    mi.util.write_bitmap(str(path), bitmap, write_async=False)
    layers = read_exr(path)
    assert sorted(layers) == sorted(channel_names())  # R, G, B, sparse.R, ..., mask.Y, ..., coverage.Y
    assert all(np.array_equal(layers[name], values) for name, values in named_channels(tensor).items())
    frame, image = unpack(tensor)
    assert np.array_equal(np.stack([layers[c] for c in "RGB"], axis=-1), image)
    assert image.mean() > 0.01 and frame.mask.sum() == round(0.25 * 32 * 32)
    assert np.array_equal(layers["mask.Y"] > 0.5, frame.mask)
    film.write(str(tmp_path / "film.exr"))  # the film's own writer: its component format, float16
    halves = read_exr(tmp_path / "film.exr")
    assert sorted(halves) == sorted(channel_names())
    np.testing.assert_allclose(halves["R"], layers["R"], rtol=1e-3, atol=1e-4)


def test_returned_tensor_takes_the_integrator_aov_names(mi, rendered, tmp_path):
    from gmcpt.io.exr import channel_names, read_exr

    scene, tensor = rendered
    names = ["R", "G", "B", *scene.integrator().aov_names()]
    assert names == channel_names()
    path = tmp_path / "named.exr"
    mi.util.write_bitmap(str(path), mi.Bitmap(tensor, channel_names=names), write_async=False)
    layers = read_exr(path)
    assert sorted(layers) == sorted(names)
    assert np.array_equal(layers["normal.Z"], tensor[..., names.index("normal.Z")])


def test_film_holds_the_last_render_only(mi):
    scene = mi.load_file(str(STILL_LIFE), res=32, spp=2, rate=0.25)
    scene.integrator().completion = "interp"  # fast; the film's content is the point
    first = np.asarray(mi.render(scene, seed=1))
    second = np.asarray(mi.render(scene, seed=2))
    assert not np.array_equal(first, second)
    assert np.array_equal(np.asarray(scene.sensors()[0].film().bitmap()), second)  # not their sum


def test_alpha_film_and_crop_window(mi):
    from gmcpt.io.exr import channel_names

    scene = mi.load_dict({
        "type": "scene",
        "integrator": {"type": "masked_path", "completion": "interp", "rate": 0.5},
        "sensor": {"type": "perspective", "sampler": {"type": "independent", "sample_count": 2},
                   "film": {"type": "hdrfilm", "width": 24, "height": 20, "pixel_format": "rgba",
                            "crop_offset_x": 4, "crop_offset_y": 2, "crop_width": 16, "crop_height": 12,
                            "rfilter": {"type": "gaussian"}}},
        "sphere": {"type": "sphere", "center": [0, 0, -4]},
        "light": {"type": "constant"},
    })
    tensor = np.asarray(mi.render(scene))
    assert tensor.shape == (12, 16, len(channel_names()))
    bitmap = scene.sensors()[0].film().bitmap()
    names = [field.name for field in bitmap.struct_()]
    assert names == ["R", "G", "B", "A", *channel_names()[3:]]
    pixels = np.asarray(bitmap)
    assert pixels.shape == (12, 16, len(names))
    assert np.array_equal(pixels[..., names.index("A")], np.ones((12, 16), np.float32))
    assert np.array_equal(np.delete(pixels, names.index("A"), axis=-1), tensor)


def test_fill_film_refuses_an_image_of_another_size(mi):
    from gmcpt.io.film import fill_film

    film = mi.load_dict({"type": "hdrfilm", "width": 8, "height": 6})
    with pytest.raises(GmcptError, match="does not fit the film"):
        fill_film(film, np.zeros((8, 8, 17), np.float32))
