"""figures.png_bytes: a lossless PNG that an independent decoder (Pillow) reads back exactly."""

import io
import zlib

import numpy as np
import pytest
from PIL import Image

from hammerstein.report import figures


def _decode(data):
    image = Image.open(io.BytesIO(data))
    image.load()
    return image


@pytest.mark.parametrize("shape", [(1, 1, 3), (1, 7, 4), (5, 1, 3), (37, 53, 3), (64, 129, 4)])
def test_random_pixels_round_trip(shape):
    pixels = np.random.default_rng(sum(shape)).integers(0, 256, shape, dtype=np.uint8)
    image = _decode(figures.png_bytes(pixels))
    assert image.mode == ("RGB" if shape[2] == 3 else "RGBA")
    assert image.size == (shape[1], shape[0])
    assert np.array_equal(np.asarray(image), pixels)


def test_strided_view_is_encoded_as_its_values():
    rgba = np.random.default_rng(3).integers(0, 256, (20, 30, 4), dtype=np.uint8)
    view = rgba[::2, ::3, :3]                          # not contiguous
    assert np.array_equal(np.asarray(_decode(figures.png_bytes(view))), view)


def test_chunks_and_up_filter_follow_the_specification():
    """Parse the file by hand: CRCs, IHDR fields, text, and every row's filter byte 2 ("Up")."""
    pixels = np.random.default_rng(5).integers(0, 256, (4, 6, 3), dtype=np.uint8)
    data = figures.png_bytes(pixels, [("Software", "test")])
    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    pos, chunks = 8, []
    while pos < len(data):
        n = int.from_bytes(data[pos:pos + 4], "big")
        kind, body = data[pos + 4:pos + 8], data[pos + 8:pos + 8 + n]
        assert int.from_bytes(data[pos + 8 + n:pos + 12 + n], "big") == zlib.crc32(kind + body)
        chunks.append((kind, body))
        pos += 12 + n
    assert [k for k, _ in chunks] == [b"IHDR", b"tEXt", b"IDAT", b"IEND"]
    assert chunks[0][1] == (6).to_bytes(4, "big") + (4).to_bytes(4, "big") + bytes([8, 2, 0, 0, 0])
    assert chunks[1][1] == b"Software\0test"
    raw = np.frombuffer(zlib.decompress(chunks[2][1]), np.uint8).reshape(4, 1 + 6 * 3)
    assert (raw[:, 0] == 2).all()
    rows = pixels.reshape(4, -1).astype(int)
    expected = np.vstack([rows[:1], (rows[1:] - rows[:-1]) % 256])      # Up: minus the row above
    assert np.array_equal(raw[:, 1:], expected)
    assert _decode(data).info["Software"] == "test"


@pytest.mark.parametrize("bad", [np.zeros((4, 4, 3), np.float64), np.zeros((4, 4), np.uint8),
                                 np.zeros((4, 4, 2), np.uint8), np.zeros((0, 4, 3), np.uint8)])
def test_bad_pixels_are_refused_with_the_field_name(bad):
    with pytest.raises(ValueError, match="pixels: expected"):
        figures.png_bytes(bad)


def test_save_keeps_a_transparent_canvas_in_rgba():
    import matplotlib.pyplot as plt
    fig = plt.figure(figsize=(1, 1))
    fig.patch.set_alpha(0.0)
    buffer = io.BytesIO()
    figures.save(fig, buffer)
    image = _decode(buffer.getvalue())
    assert image.mode == "RGBA" and np.asarray(image)[..., 3].min() < 255
