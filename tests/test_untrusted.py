"""sensors.untrusted: every limit on input from outside, tried with hostile inputs on real files,
FIFOs, devices, sockets, symlink loops, real zstd/lz4/JPEG/PNG bytes, and a 512 MB memory cap."""

from __future__ import annotations

import copy
import json
import os
import shutil
import socket
import stat
import struct
import subprocess
import sys
import textwrap
import time
import tomllib
from collections.abc import Callable, Iterator
from pathlib import Path

import numpy as np
import pytest
from hang_guard import within

from sensors.untrusted import (
    MissingInput,
    Timeline,
    UntrustedInput,
    budget_for,
    check_image,
    check_raw_image,
    decompress,
    finite,
    image_size_from_header,
    load_json,
    load_toml,
    one_line,
    open_regular,
    parse_json,
    parse_toml,
    read_bytes,
    read_text,
    resolve_within,
    shorten,
    systemd_environment,
    systemd_escape,
    systemd_exec_argument,
    systemd_exec_path,
    systemd_path,
    systemd_text,
    systemd_user,
    whole,
    write_owned,
)
from sensors.untrusted import limits as L
from sensors.untrusted.structured import json_shape, toml_shape

ROOT = Path(__file__).resolve().parent.parent


def _refused(fn: Callable[[], object], *words: str, seconds: float = 10.0) -> str:
    """The one-line message of the UntrustedInput that ``fn`` raises within ``seconds``, holding ``words``."""
    with pytest.raises(UntrustedInput) as caught:
        within(seconds, fn)
    message = str(caught.value)
    assert "\n" not in message and len(message) < 600, message
    for word in words:
        assert word in message, message
    return message


@pytest.fixture()
def fifo(tmp_path: Path) -> Path:
    path = tmp_path / "config.toml"
    os.mkfifo(path)
    return path


@pytest.fixture()
def unix_socket(tmp_path: Path) -> Iterator[Path]:
    path = tmp_path / "health.sock"
    sock = socket.socket(socket.AF_UNIX)
    sock.bind(str(path))
    yield path
    sock.close()


def _mknod(path: Path, kind: int, major: int, minor: int) -> Path:
    """A device node like /dev/full (1, 7), made in a test folder; skips where mknod is not allowed."""
    try:
        os.mknod(path, kind | 0o666, os.makedev(major, minor))
    except PermissionError:
        pytest.skip("mknod is not permitted here (needs root / CAP_MKNOD)")
    return path


# ---------------------------------------------------------------- the error and shortened values


def test_a_ten_megabyte_value_is_never_echoed_whole() -> None:
    big = "a" * 10_485_760
    assert shorten(big) == "'" + "a" * 40 + "…' (10485760 characters)"
    assert shorten(b"\0" * 5000).endswith("…' (5000 bytes)")
    assert shorten(10**100_000) == "an integer of 332193 bits"  # str() of it would refuse (4300 digits)
    assert shorten(-(10**200)) == "a negative integer of 665 bits"
    assert shorten(list(range(1_000_000))) == "a list of 1000000 items"
    assert shorten("ok") == "'ok'" and shorten(1.5) == "1.5" and shorten(None) == "None"
    e = UntrustedInput("configs/demo.toml", f"[run] name: expected a short name, got {shorten(big)}")
    assert str(e) == "configs/demo.toml: [run] name: expected a short name, got 'aaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaa…' (10485760 characters)"


def test_the_error_is_one_line_a_value_error_and_picklable() -> None:
    e = UntrustedInput("evil\nname.toml", "bad\rvalue\u2028here")
    assert isinstance(e, ValueError)
    assert str(e) == "'evil\\nname.toml': bad\\rvalue\\u2028here"
    assert e.source == "evil\nname.toml" and e.problem == "bad\rvalue\u2028here"
    again = copy.copy(e)  # through __reduce__, as pickle goes
    assert type(again) is UntrustedInput and str(again) == str(e)
    assert len(str(UntrustedInput("f", "x" * 100_000))) < 500
    assert one_line("a\tb\x00c") == "a\\tb\\x00c"


def test_a_missing_file_is_both_untrusted_input_and_file_not_found(tmp_path: Path) -> None:
    e = MissingInput(tmp_path / "nope.toml")
    assert isinstance(e, UntrustedInput) and isinstance(e, FileNotFoundError)
    assert e.filename == str(tmp_path / "nope.toml") and e.errno == 2
    assert str(e) == f"{tmp_path / 'nope.toml'}: no such file"
    assert str(copy.copy(e)) == str(e)


# ---------------------------------------------------------------- opening and reading files


def test_a_regular_file_is_read(tmp_path: Path) -> None:
    path = tmp_path / "a.toml"
    path.write_bytes(b"x = 1\n")
    with open_regular(path) as f:
        assert f.read() == b"x = 1\n"
    assert read_bytes(path, 6, "config") == b"x = 1\n"
    link = tmp_path / "link.toml"
    link.symlink_to(path)
    assert read_text(link, 100, "config") == "x = 1\n"


def test_a_fifo_is_refused_by_name_without_hanging(fifo: Path) -> None:
    _refused(lambda: open_regular(fifo), str(fifo), "is a FIFO, expected a regular file", seconds=5)
    _refused(lambda: read_bytes(fifo, 1000, "config"), "is a FIFO", seconds=5)
    _refused(lambda: load_toml(fifo), "is a FIFO", seconds=5)
    link = fifo.parent / "via-link.toml"
    link.symlink_to(fifo)
    _refused(lambda: read_text(link, 1000), "is a FIFO", seconds=5)


def test_a_fifo_with_a_writer_attached_is_refused_too(fifo: Path) -> None:
    writer = os.open(fifo, os.O_RDWR | os.O_NONBLOCK)  # RDWR: a FIFO can be held open by one process
    try:
        os.write(writer, b"x = 1\n")
        _refused(lambda: read_bytes(fifo, 1000), "is a FIFO", seconds=5)
    finally:
        os.close(writer)


@pytest.mark.parametrize("device", ["/dev/zero", "/dev/null", "/dev/urandom"])
def test_devices_are_refused_and_never_read(device: str) -> None:
    if not os.path.exists(device):
        pytest.skip(f"{device} is missing")
    _refused(lambda: read_bytes(device, L.CONFIG_TOML.max_bytes, "config"), device,
             "is a character device, expected a regular file", seconds=5)
    _refused(lambda: load_toml(device), "is a character device", seconds=5)
    _refused(lambda: load_json(device), "is a character device", seconds=5)


def test_a_block_device_is_refused(tmp_path: Path) -> None:
    node = _mknod(tmp_path / "disk", stat.S_IFBLK, 7, 0)  # loop0's numbers; never opened
    _refused(lambda: read_bytes(node, 100), "is a block device, expected a regular file")


def test_a_folder_and_a_socket_are_refused_by_name(tmp_path: Path, unix_socket: Path) -> None:
    _refused(lambda: read_bytes(tmp_path, 100), "is a folder, expected a regular file")
    _refused(lambda: read_bytes(unix_socket, 100), "is a socket, expected a regular file")


def test_a_symlink_loop_a_missing_file_and_odd_names_are_user_errors(tmp_path: Path) -> None:
    a, b = tmp_path / "a.toml", tmp_path / "b.toml"
    a.symlink_to(b)
    b.symlink_to(a)
    _refused(lambda: read_bytes(a, 100), "symbolic links")
    with pytest.raises(FileNotFoundError) as missing:
        read_bytes(tmp_path / "nope.toml", 100)
    assert isinstance(missing.value, MissingInput) and "no such file" in str(missing.value)
    (tmp_path / "file").write_text("x")
    _refused(lambda: read_bytes(tmp_path / "file" / "x.toml", 100), "not a folder")
    _refused(lambda: read_bytes(str(tmp_path / "nul\0name"), 100), "NUL")
    _refused(lambda: read_bytes(tmp_path / ("x" * 5000), 100), "too long")
    message = _refused(lambda: read_bytes(tmp_path / "new\nline.toml", 100), "no such file")
    assert "new\\nline.toml" in message


def test_reads_are_bounded(tmp_path: Path) -> None:
    path = tmp_path / "pose.toml"
    path.write_bytes(b"x" * 1001)
    assert len(read_bytes(path, 1001)) == 1001
    _refused(lambda: read_bytes(path, 1000, "pose file"), str(path), "pose file of 1001 bytes is larger than the 1000 bytes allowed")
    # /proc files report size 0 yet hold bytes: the read itself stops at limit + 1
    status = Path("/proc/self/status")
    if status.exists():
        _refused(lambda: read_bytes(status, 16, "status"), "larger than the 16 bytes allowed")


def test_text_that_is_not_utf8_is_refused_with_its_line(tmp_path: Path) -> None:
    path = tmp_path / "c.toml"
    path.write_bytes(b"a = 1\nb = 2\nc = '\xff'\n")
    _refused(lambda: read_text(path, 100, "config"), "config is not utf-8 text (byte 0xff on line 3)")
    path.write_bytes("\ufeffa = 1\n".encode())
    assert read_text(path, 100) == "a = 1\n"


def test_a_reference_from_a_file_stays_inside_its_folder(tmp_path: Path) -> None:
    (tmp_path / "set").mkdir()
    (tmp_path / "set" / "mesh.bin").write_bytes(b"\0")
    assert resolve_within(tmp_path / "set", "mesh.bin", "buffer uri") == (tmp_path / "set" / "mesh.bin").resolve()
    _refused(lambda: resolve_within(tmp_path / "set", "../../../../../../etc/passwd", "buffer uri"), "leads outside")
    _refused(lambda: resolve_within(tmp_path / "set", "/etc/passwd", "buffer uri"), "expected a relative path")
    _refused(lambda: resolve_within(tmp_path / "set", "", "buffer uri"), "expected a relative path")
    (tmp_path / "set" / "out.bin").symlink_to("/etc/passwd")
    _refused(lambda: resolve_within(tmp_path / "set", "out.bin", "buffer uri"), "leads outside")


# ---------------------------------------------------------------- writing


def test_write_owned_creates_and_replaces_regular_files_atomically(tmp_path: Path) -> None:
    path = tmp_path / "health.json"
    assert write_owned(path, '{"ok": true}') == path
    assert path.read_text() == '{"ok": true}'
    os.chmod(path, 0o600)
    inode = path.stat().st_ino
    write_owned(path, b"{}")
    assert path.read_bytes() == b"{}" and stat.S_IMODE(path.stat().st_mode) == 0o600
    assert path.stat().st_ino != inode  # replaced, not written in place
    assert sorted(p.name for p in tmp_path.iterdir()) == ["health.json"]  # no temporary file left


def _never_replace(*args: object) -> None:
    raise AssertionError(f"os.replace was called for {args}")


def test_write_owned_never_replaces_the_real_dev_full(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(os, "replace", _never_replace)  # even a bug here could not touch /dev
    if not os.path.exists("/dev/full"):
        pytest.skip("/dev/full is missing")
    _refused(lambda: write_owned("/dev/full", b"{}"), "/dev/full: is a character device, expected a regular file")
    assert stat.S_ISCHR(os.lstat("/dev/full").st_mode)


def test_write_owned_refuses_special_files_even_as_root(tmp_path: Path, fifo: Path, unix_socket: Path) -> None:
    full = _mknod(tmp_path / "full", stat.S_IFCHR, 1, 7)  # a /dev/full of our own
    for target, kind in ((full, "character device"), (fifo, "FIFO"), (unix_socket, "socket"), (tmp_path, "folder")):
        _refused(lambda t=target: write_owned(t, b"{}"), f"is a {kind}, expected a regular file", seconds=5)  # type: ignore[misc]
    assert stat.S_ISCHR(full.lstat().st_mode) and stat.S_ISFIFO(fifo.lstat().st_mode)
    assert stat.S_ISSOCK(unix_socket.lstat().st_mode)
    assert not [p for p in tmp_path.iterdir() if p.name.endswith(".part")]


def test_write_owned_does_not_follow_a_symlink_nor_write_into_a_missing_folder(tmp_path: Path) -> None:
    victim = tmp_path / "victim"
    victim.write_text("precious")
    link = tmp_path / "health.json"
    link.symlink_to(victim)
    _refused(lambda: write_owned(link, b"{}"), "is a symbolic link")
    assert victim.read_text() == "precious" and link.is_symlink()
    (tmp_path / "dir").mkdir()
    dir_link = tmp_path / "dir-link"
    dir_link.symlink_to(tmp_path / "dir")
    _refused(lambda: write_owned(dir_link, b"{}"), "is a symbolic link")
    _refused(lambda: write_owned(tmp_path / "no" / "such" / "x.json", b"{}"), "cannot write here")
    _refused(lambda: write_owned(victim / "x.json", b"{}"), "a part of the path is not a folder")
    _refused(lambda: write_owned(tmp_path / "nul\0x", b"{}"), "NUL")


# ---------------------------------------------------------------- TOML and JSON


def test_a_dotted_key_of_20000_parts_is_refused_before_tomllib_runs(tmp_path: Path) -> None:
    text = "[run]\nname = 'x'\n" + "a" + ".a" * 20000 + " = 1\n"  # 40 KB: tomllib took 2.4 GB and 30 s
    path = tmp_path / "config.toml"
    path.write_text(text)
    t0 = time.perf_counter()
    _refused(lambda: load_toml(path), str(path), "line 3: a dotted key of 20001 parts, more than the 16 allowed")
    assert time.perf_counter() - t0 < 2.0


@pytest.mark.parametrize("value", ["[" * 3000 + "]" * 3000, "{a = " * 3000 + "1" + "}" * 3000,
                                   "[" * 3000, "[{x=[" * 1000])
def test_toml_nested_thousands_deep_is_refused_not_a_recursion_error(value: str) -> None:
    _refused(lambda: parse_toml(f"a = 1\nx = {value}\n", "deep.toml"), "deep.toml: line 2: TOML nested", "more than the 16 allowed")


def test_toml_with_too_many_items_is_refused() -> None:
    text = "x = [" + "1," * 60_000 + "]\n"
    _refused(lambda: parse_toml(text, "c.toml", L.CONFIG_TOML), "keys and items, more than the 10000 allowed")
    sensors = "".join(f"[[sensors]]\nname = 's{i}'\nkind = 'webcam'\n" for i in range(10_000))  # was 5.5 GB
    assert len(sensors) < L.CONFIG_TOML.max_bytes
    _refused(lambda: parse_toml(sensors, "c.toml", L.CONFIG_TOML), "more than the 10000 allowed")
    assert parse_toml(text, "pose.toml", L.POSE_FILE)["x"] == [1] * 60_000
    _refused(lambda: parse_toml("x = 'ab'", "c.toml", L.InputLimits(max_bytes=5)), "more than the 5 allowed")


def test_brackets_dots_and_commas_inside_strings_and_comments_do_not_count() -> None:
    text = textwrap.dedent('''\
        # [[[[[[[[[[[[[[[[[[[[ a.b.c.d.e.f.g.h.i.j.k.l.m.n.o.p.q.r
        "a.b.c.d.e.f.g.h.i.j.k.l.m.n.o.p.q" = 1
        s = "[[[[[[[[[[[[[[[[[[[[[[ \\" [[[[[[[[[[[[[[[[[[[["
        m = """
        [[[[[[[[[[[[[[[[[[[[ "" [[[[[[[[[[[[[ \\""" [[[[[[[[[[[[[[[["""
        lit = '[[[[[[[[[[[[[[[[[[[[\\'
        ml = \'\'\'[[[[[[[[[[[[[[[[[[[[ '' [[[[[[[[[[[[\'\'\'\'
        when = 1979-05-27T07:32:00.999999-07:00
        [a."b.c.d.e.f.g.h.i.j.k.l.m.n.o.p.q.r.s".d]
        x = { y = [1.5, 2.5], z = "}}}}}}}}}}}}}}}}}}}}}}" }
        ''')
    assert parse_toml(text, "ok.toml") == tomllib.loads(text)


def _true_depth(value: object) -> int:
    if isinstance(value, dict):
        return 1 + max((_true_depth(v) for v in value.values()), default=0)
    if isinstance(value, list):
        return 1 + max((_true_depth(v) for v in value), default=0)
    return 0


def test_every_shipped_toml_file_parses_as_tomllib_parses_it_and_the_scan_never_counts_low() -> None:
    files = sorted((ROOT / "configs").rglob("*.toml"))
    assert len(files) > 10
    for path in files:
        text = path.read_text(encoding="utf-8")
        parsed = load_toml(path, L.POSE_FILE)
        assert parsed == tomllib.loads(text), path
        depth, parts, items = toml_shape(text)
        assert depth + parts >= _true_depth(parsed) - 1, path  # headers' nesting is in dotted parts
        assert depth <= 4 and parts <= 2 and items < L.POSE_FILE.max_items, path


def test_toml_syntax_errors_name_the_file_and_line(tmp_path: Path) -> None:
    path = tmp_path / "broken.toml"
    path.write_text("[run]\nduration_s = 10\nname = \n")
    _refused(lambda: load_toml(path, L.CONFIG_TOML, "config"), str(path), "not valid TOML", "line 3")
    path.write_text("x = 1\nx = 2\n")
    _refused(lambda: load_toml(path), "line 2")
    _refused(lambda: parse_toml("x = " + "9" * 5000, "c.toml"), "c.toml: not valid TOML", "4300 digits")
    _refused(lambda: parse_toml("x = 1979-02-30T25:00:00", "c.toml"), "Invalid date")


def test_json_nested_100k_deep_is_refused_and_other_hostile_json() -> None:
    _refused(lambda: parse_json("[" * 100_000 + "]" * 100_000, "truth.json"), "truth.json: line 1: JSON nested 100000 deep")
    _refused(lambda: parse_json("[NaN]", "t.json"), "NaN is not a JSON number")
    _refused(lambda: parse_json("[-Infinity]", "t.json"), "-Infinity is not a JSON number")
    _refused(lambda: parse_json("1" * 5000, "t.json"), "not valid JSON", "4300 digits")
    _refused(lambda: parse_json('{"a":\n [1,', "t.json"), "not valid JSON", "line 2")
    _refused(lambda: parse_json(b'"\xff"', "t.json"), "not utf-8")
    _refused(lambda: parse_json("[" + "0," * 300_000 + "0]", "t.json"), "more than the 200000 allowed")
    _refused(lambda: parse_json(b"[]" * 1_000_000, "m", L.MESSAGE_JSON), "bytes of JSON, more than the 1048576 allowed")
    text = '{"a": "[[[[{{{{ \\" [[[[", "b": [1, 2.5, {"c": null}]}'
    assert parse_json(text, "ok.json") == json.loads(text)
    assert json_shape(text)[0] == 3


def test_load_json_reads_a_bounded_regular_file(tmp_path: Path) -> None:
    path = tmp_path / "notes.json"
    path.write_text('{"frames": 3}')
    assert load_json(path) == {"frames": 3}
    path.write_bytes(b" " * (L.JSON_SIDECAR.max_bytes + 1))
    _refused(lambda: load_json(path, what="sidecar"), "sidecar of 4194305 bytes (4 MiB) is larger than the 4 MiB allowed")


# ---------------------------------------------------------------- images


def _jpeg(width: int = 64, height: int = 48, progressive: bool = False) -> bytes:
    import cv2

    image = np.random.default_rng(1).integers(0, 255, (height, width, 3), dtype=np.uint8)
    ok, buf = cv2.imencode(".jpg", image, [cv2.IMWRITE_JPEG_PROGRESSIVE, int(progressive)])
    assert ok
    return bytes(buf)


def _png(width: int = 64, height: int = 48) -> bytes:
    import cv2

    ok, buf = cv2.imencode(".png", np.zeros((height, width), dtype=np.uint16))
    assert ok
    return bytes(buf)


def _claim(data: bytes, width: int, height: int) -> bytes:
    """``data`` with its header patched to claim ``width`` × ``height`` (the pixels left as they are)."""
    if data.startswith(b"\x89PNG"):
        return data[:16] + struct.pack(">II", width, height) + data[24:]
    i = 2
    while data[i + 1] not in (0xC0, 0xC1, 0xC2):
        i += 2 + struct.unpack(">H", data[i + 2:i + 4])[0]
    return data[:i + 5] + struct.pack(">HH", height, width) + data[i + 9:]


def test_real_jpeg_and_png_sizes_come_from_their_headers() -> None:
    assert image_size_from_header(_jpeg(64, 48)) == (64, 48)
    assert image_size_from_header(_jpeg(33, 17, progressive=True)) == (33, 17)
    assert image_size_from_header(_png(640, 480)) == (640, 480)
    assert check_image(_jpeg(64, 48), "cam/color frame 3") == (64, 48)
    for bad in (b"", b"\xff\xd8", b"\xff\xd8\xff\xe0\x00", b"GIF89a" + b"\0" * 30, b"\x89PNG\r\n\x1a\n\0\0",
                b"\xff\xd8\xff\xda\x00\x02", b"\xff\xd8" + b"\xff\xe1\xff\xff" + b"\0" * 100, _jpeg()[:20]):
        assert image_size_from_header(bad) is None, bad


def test_an_image_claiming_30000_by_30000_is_refused_before_decoding() -> None:
    small = _jpeg(64, 48)
    huge = _claim(small, 30000, 30000)
    assert len(huge) < 20_000 and image_size_from_header(huge) == (30000, 30000)
    _refused(lambda: check_image(huge, "cam/color frame 11"), "cam/color frame 11: the image header declares 30000 × 30000 pixels")
    _refused(lambda: check_image(_claim(_jpeg(33, 17, progressive=True), 65000, 65000), "f"), "65000 × 65000")
    _refused(lambda: check_image(_claim(_png(), 20000, 20000), "f"), "20000 × 20000")
    _refused(lambda: check_image(_claim(small, 0, 48), "f"), "declares 0 × 48 pixels")
    _refused(lambda: check_image(_claim(_png(), 64, 0), "f"), "declares 64 × 0 pixels")
    _refused(lambda: check_image(b"", "f"), "empty")
    _refused(lambda: check_image(b"BM" + b"\0" * 100, "f"), "not a JPEG or PNG")
    _refused(lambda: check_image(small, "f", max_pixels=64 * 47), "more than the 3008 allowed")


def test_a_raw_depth_image_is_checked_against_its_payload() -> None:
    check_raw_image(640, 480, 1280, 2, 640 * 480 * 2, "cam/depth frame 0")
    check_raw_image(5, 2, 16, 3, 32, "padded rows")
    _refused(lambda: check_raw_image(14000, 14000, 28000, 2, 15_000, "cam/depth frame 7"),
             "cam/depth frame 7: the image declares 14000 × 14000 pixels, more than")
    _refused(lambda: check_raw_image(4000, 4000, 8000, 2, 15_000, "d"), "15000 bytes of pixels, but 4000 × 4000")
    _refused(lambda: check_raw_image(0, 480, 0, 2, 0, "d"), "declares 0 × 480")
    _refused(lambda: check_raw_image(-1, 480, 0, 2, 0, "d"), "declares -1 × 480")
    _refused(lambda: check_raw_image(640, 480, 640, 2, 640 * 480, "d"), "row step of 640 bytes is less")
    _refused(lambda: check_raw_image(2, 2, 2**40, 2, 2**41, "d"), "row step")


# ---------------------------------------------------------------- decompression


def _zstd_zeros(size: int, with_content_size: bool = True) -> bytes:
    import zstandard

    compressor = zstandard.ZstdCompressor(level=1, write_content_size=with_content_size)
    stream = compressor.compressobj(size=size if with_content_size else -1)
    block = bytes(1 << 20)
    out = [stream.compress(block) for _ in range(size >> 20)]
    return b"".join(out) + stream.flush()


def test_budget_for_ties_the_budget_to_the_input_size() -> None:
    assert budget_for(0) == budget_for(-5) == L.DECOMPRESS_FLOOR == 64 << 20
    assert budget_for(1 << 20) == 64 << 20
    assert budget_for(int(1.5 * (1 << 20))) == 96 << 20
    assert budget_for(10 << 20) == budget_for(1 << 40) == L.DECOMPRESS_CAP == 128 << 20


def test_a_37_kb_zstd_chunk_claiming_gigabytes_is_refused_without_allocating() -> None:
    bomb = _zstd_zeros(1 << 30)  # 1 GiB of zeros in ~32 KB, its frame header honest about the size
    assert len(bomb) < 40_000
    budget = budget_for(len(bomb))
    _refused(lambda: decompress(bomb, "zstd", 1 << 30, budget, "chunk 0"), "chunk 0: claims 1 GiB uncompressed from", "more than the 64 MiB allowed")
    # the chunk lies (claims 1 MiB); the frame header says 1 GiB; either way output stops at 1 MiB + 1
    t0 = time.perf_counter()
    _refused(lambda: decompress(bomb, "zstd", 1 << 20, budget, "chunk 0"), "decompresses to more than the 1 MiB it claims")
    _refused(lambda: decompress(_zstd_zeros(64 << 20, with_content_size=False), "zstd", 1000, budget, "c"), "more than")
    assert time.perf_counter() - t0 < 5


def test_zstd_and_lz4_round_trip_and_every_lie_is_caught() -> None:
    import lz4.frame  # type: ignore[import-untyped]
    import zstandard

    raw = np.random.default_rng(2).integers(0, 4000, 300_000, dtype=np.uint16).tobytes()
    for name, packed in (("zstd", zstandard.ZstdCompressor(level=19).compress(raw)), ("lz4", lz4.frame.compress(raw)), ("", raw)):
        assert decompress(packed, name, len(raw), budget_for(len(packed)), "c") == raw
        _refused(lambda p=packed, n=name: decompress(p, n, len(raw) - 1, budget_for(len(p)), "c"), "more than")  # type: ignore[misc]
        _refused(lambda p=packed, n=name: decompress(p, n, len(raw) + 1, budget_for(len(p)), "c"), "not the")  # type: ignore[misc]
        if name:
            _refused(lambda p=packed, n=name: decompress(p[:-50], n, len(raw), budget_for(len(p)), "c"), "c: ")  # type: ignore[misc]
            _refused(lambda n=name: decompress(b"\0garbage" * 20, n, len(raw), budget_for(160), "c"), "corrupt")  # type: ignore[misc]
    lz4_bomb = lz4.frame.compress(bytes(64 << 20))
    _refused(lambda: decompress(lz4_bomb, "lz4", 1 << 20, budget_for(len(lz4_bomb)), "chunk 2"), "more than the 1 MiB it claims")
    _refused(lambda: decompress(lz4.frame.compress(raw) * 2, "lz4", len(raw), budget_for(1 << 20), "c"), "after the end of the lz4 frame")
    _refused(lambda: decompress(b"", "bz2", 0, 1, "chunk 1"), "compression 'bz2' is not supported")
    _refused(lambda: decompress(b"x", "zstd", -1, 10, "chunk 1"), "claims")


def test_every_chunk_of_a_real_recording_decompresses_as_mcap_does_it() -> None:
    import zlib

    import zstandard
    from mcap.records import Chunk
    from mcap.stream_reader import StreamReader

    chunks = 0
    with open(ROOT / "tests" / "fixtures" / "group3.mcap", "rb") as f:
        for record in StreamReader(f, emit_chunks=True).records:
            if isinstance(record, Chunk):
                mine = decompress(record.data, record.compression, record.uncompressed_size,
                                  budget_for(len(record.data)), f"chunk {chunks}")
                assert mine == zstandard.decompress(record.data, record.uncompressed_size)  # what mcap does
                assert zlib.crc32(mine) == record.uncompressed_crc
                chunks += 1
    assert chunks == 7


# ---------------------------------------------------------------- numbers and time


@pytest.mark.parametrize(("value", "words"), [
    (float("nan"), "expected a finite number, got nan"),
    (float("inf"), "expected a finite number, got inf"),
    (-float("inf"), "got -inf"),
    (1e308, "expected a number from 0 to 3.16224e+07, got 1e+308"),
    (-1, "got -1"),
    (True, "expected a number, got True"),
    ("nan", "expected a number, got 'nan'"),
    (None, "got None"),
    ("9" * 10_000_000, "(10000000 characters)"),
])
def test_finite_refuses_what_no_duration_can_be(value: object, words: str) -> None:
    _refused(lambda: finite(value, "[run] duration_s", 0, L.DURATION_MAX_S), "[run] duration_s: ", words)


def test_finite_and_whole_keep_good_numbers_and_refuse_seeds_and_int32_extremes() -> None:
    assert finite(2.5, "x", 0, 3) == 2.5 and finite(3, "x") == 3 and isinstance(finite(3, "x"), int)
    assert finite(np.float32(0.5), "x") == 0.5 and type(finite(np.int64(7), "x")) is int
    assert whole(0, "seed", 0, L.SEED_MAX) == 0 and whole(np.uint32(5), "seed", 0) == 5
    _refused(lambda: whole(-1, "seed", 0, L.SEED_MAX), "seed: expected a whole number from 0 to 4294967295, got -1")
    _refused(lambda: whole(1.5, "seed"), "expected a whole number, got 1.5")
    _refused(lambda: whole(2**31, "pads: count", 0, 2**31 - 1), "got 2147483648")
    _refused(lambda: finite(-(2**31), "pad 3: force_n", -5000, 5000), "from -5000 to 5000, got -2147483648")
    _refused(lambda: finite(5.4e8, "pad 3: force_n", hi=5000), "≤ 5000, got 540000000.0")
    _refused(lambda: finite(10**5000, "x", hi=1), "an integer of 16610 bits")


def test_a_frame_stamped_ten_to_the_19_ns_after_one_at_1_s_is_refused() -> None:
    timeline = Timeline("recording.mcap: cam/depth")
    assert timeline.check(1_000_000_000) == 1_000_000_000
    assert timeline.flag(1_033_000_000) is None
    problem = timeline.flag(10**19 - 1)
    assert problem is not None and "outside 0 … 9223372036854775807 ns" in problem
    problem = timeline.flag(9 * 10**18)
    assert problem is not None and "more than the 300 s allowed" in problem
    assert timeline.last_ns == 1_033_000_000 and timeline.refused == 2  # refused stamps are not taken
    _refused(lambda: timeline.check(1_000_000_000), "recording.mcap: cam/depth: timestamp 1000000000 ns goes back 33000000 ns")
    _refused(lambda: timeline.check(-1), "outside")
    _refused(lambda: timeline.check(1.5e9), "whole nanoseconds, got 1500000000.0")
    assert timeline.check(np.int64(1_066_000_000)) == 1_066_000_000
    assert timeline.check(1_066_000_000) == 1_066_000_000  # equal stamps are allowed
    assert Timeline("s", max_gap_ns=10).flag(5) is None


# ---------------------------------------------------------------- systemd units


def test_exec_arguments_are_quoted_by_systemds_rules() -> None:
    assert systemd_exec_argument("/opt/jostle/bin/jostle", "a") == "/opt/jostle/bin/jostle"
    assert systemd_exec_argument("--no-video", "a") == "--no-video"
    assert systemd_exec_argument("/srv/my configs/demo.toml", "a") == '"/srv/my configs/demo.toml"'
    assert systemd_exec_argument('a"b\\c', "a") == '"a\\"b\\\\c"'
    assert systemd_exec_argument("$HOME;%h", "a") == '"$$HOME;%%h"'
    assert systemd_exec_argument(";", "a") == '";"' and systemd_exec_argument("", "a") == '""'
    assert systemd_exec_path("/opt/j o/bin/jostle", "jostle") == '"/opt/j o/bin/jostle"'
    _refused(lambda: systemd_exec_path("bin/jostle", "jostle"), "absolute path")
    _refused(lambda: systemd_exec_path("/opt/$x/jostle", "jostle"), "'$' in the program's path")


@pytest.mark.parametrize("bad", ["a\nb", ":0\nExecStartPre=/bin/touch /tmp/pwned", "a\rb", "a\tb", "a\0b", "a\x7fb",
                                 "a\u2028b", "a\u2029b", "a\u202eb", "a\x85b", "a\udcffb"])
def test_a_newline_or_control_character_is_refused_everywhere(bad: str) -> None:
    for fn in (lambda: systemd_exec_argument(bad, "--display"), lambda: systemd_exec_path("/x/" + bad, "--display"),
               lambda: systemd_path("/x/" + bad, "--display"), lambda: systemd_environment("DISPLAY", bad, "--display"),
               lambda: systemd_user(bad, "--display"), lambda: systemd_text(bad, "--display")):
        _refused(fn, "--display: holds ", "refused in a systemd unit")


def test_working_directory_paths_are_written_verbatim_or_refused() -> None:
    assert systemd_path("/srv/my configs", "config folder") == "/srv/my configs"
    assert systemd_path('/srv/"quoted" $x;ü\\y', "c") == '/srv/"quoted" $x;ü\\y'
    assert systemd_path("/srv/100%", "c") == "/srv/100%%"
    assert systemd_path("/srv/ends in space ", "c") == "/srv/ends in space /"
    assert systemd_path("/srv/ends\\", "c") == "/srv/ends\\/"
    _refused(lambda: systemd_path("configs", "config folder"), "config folder: 'configs': expected an absolute path")
    _refused(lambda: systemd_path("/srv/../etc", "c"), "'..'")
    _refused(lambda: systemd_path("/srv/" + "x" * 256, "c"), "longer than 255 bytes")
    _refused(lambda: systemd_path("/" + "x/" * 3000, "c"), "more than the 4095")


def test_environment_user_text_and_unit_names() -> None:
    assert systemd_environment("DISPLAY", ":0", "--display") == '"DISPLAY=:0"'
    assert systemd_environment("XAUTHORITY", '/h/a b/"x"\\%', "x") == '"XAUTHORITY=/h/a b/\\"x\\"\\\\%%"'
    _refused(lambda: systemd_environment("A B", "x", "env"), "not an environment variable name")
    assert systemd_user("kiosk", "--run-as") == "kiosk" and systemd_user("1000", "--run-as") == "1000"
    for bad in ("!!!", "root;x", "a b", "", "-x", "x" * 32, "4294967295"):
        _refused(lambda b=bad: systemd_user(b, "--run-as"), "--run-as: ", "not a user name")  # type: ignore[misc]
    assert systemd_text("  jostle 100% (demo.toml) ", "d") == "jostle 100%% (demo.toml)"
    _refused(lambda: systemd_text("ends\\", "Description"), "backslash")
    assert systemd_escape("!!!") == "\\x21\\x21\\x21"


@pytest.mark.skipif(shutil.which("systemd-escape") is None, reason="systemd-escape is not installed")
@pytest.mark.parametrize("text", ["demo", "!!!", "my config/ü-1", ".hidden", "a b;$%\\\"'", "x.y:z_w"])
def test_unit_name_escapes_match_systemd_escape(text: str) -> None:
    out = subprocess.run(["systemd-escape", "--", text], capture_output=True, text=True, timeout=30, check=True)
    assert systemd_escape(text) == out.stdout.strip()


def _dumped_argv(line: str) -> list[str]:
    """The argv in systemd-analyze's dump ("Command Line: …"): words, or double-quoted with \\ escapes."""
    words, i = [], 0
    while i < len(line):
        if line[i] == " ":
            i += 1
            continue
        word = []
        if line[i] == '"':
            i += 1
            while line[i] != '"':
                if line[i] == "\\":
                    i += 1
                word.append(line[i])
                i += 1
            i += 1
        else:
            while i < len(line) and line[i] != " ":
                word.append(line[i])
                i += 1
        words.append("".join(word))
    return words


@pytest.mark.skipif(shutil.which("systemd-analyze") is None, reason="systemd-analyze is not installed")
def test_systemd_analyze_verify_reads_hostile_values_back_exactly(tmp_path: Path) -> None:
    folder = tmp_path / "my \"conf\" $dir;100% ü\\x "  # space, quotes, $, ;, %, non-ASCII, backslash, trailing space
    folder.mkdir()
    program = tmp_path / "bin dir" / "jostle"
    program.parent.mkdir()
    program.write_text("#!/bin/sh\n")
    program.chmod(0o755)
    args = [str(folder / "demo.toml"), "--display", ":0 $DISPLAY ${X} %h", "--out", 'a"b\\c', ";", "", "\\;", "-"]
    unit = tmp_path / "jostle-test.service"
    unit.write_text("\n".join([
        "[Unit]", f"Description={systemd_text('jostle 100% test', 'd')}", "", "[Service]", "Type=simple",
        "ExecStart=" + " ".join([systemd_exec_path(program, "jostle")] + [systemd_exec_argument(a, "arg") for a in args]),
        f"WorkingDirectory={systemd_path(folder, 'config folder')}",
        "Environment=" + systemd_environment("DISPLAY", ':0 "x" $y %h', "--display"),
        f"User={systemd_user('root', '--run-as')}", "",
    ]))
    plain = subprocess.run(["systemd-analyze", "verify", str(unit)], capture_output=True, text=True, timeout=120)
    assert plain.returncode == 0, plain.stderr
    assert "jostle-test.service" not in plain.stderr, plain.stderr
    env = dict(os.environ, SYSTEMD_LOG_LEVEL="debug")
    debug = subprocess.run(["systemd-analyze", "verify", str(unit)], capture_output=True, text=True, timeout=120, env=env)
    dump = debug.stdout + debug.stderr
    command = [ln.split("Command Line: ", 1)[1] for ln in dump.splitlines() if "Command Line: " in ln]
    assert len(command) == 1, dump[-3000:]
    # systemd keeps $$ in argv until it runs the command (then $$ is $); specifiers are already expanded
    assert _dumped_argv(command[0]) == [str(program)] + [a.replace("$", "$$") for a in args]
    assert f"\t\tWorkingDirectory: {folder}\n" in dump
    assert '\t\tEnvironment: DISPLAY=:0 "x" $y %h\n' in dump


@pytest.mark.skipif(shutil.which("systemd-analyze") is None, reason="systemd-analyze is not installed")
def test_systemd_analyze_verify_refuses_what_the_old_quoting_wrote(tmp_path: Path) -> None:
    """The control: a quoted WorkingDirectory= (issue N, finding 4) is refused by systemd itself."""
    unit = tmp_path / "jostle-old.service"
    unit.write_text(f'[Service]\nExecStart=/bin/true\nWorkingDirectory="{tmp_path}"\n')
    out = subprocess.run(["systemd-analyze", "verify", str(unit)], capture_output=True, text=True, timeout=120)
    assert out.returncode != 0 and "not absolute" in out.stderr


# ---------------------------------------------------------------- under a 512 MB address-space cap

_CAPPED = r'''
import os, resource, sys, json
resource.setrlimit(resource.RLIMIT_AS, (512 << 20, 512 << 20))
import zstandard, lz4.frame
from sensors.untrusted import (UntrustedInput, budget_for, check_image, check_raw_image, decompress, parse_json,
                               parse_toml, read_bytes, load_toml)
from sensors.untrusted.limits import CONFIG_TOML

def zeros_zstd(size):
    stream = zstandard.ZstdCompressor(level=1).compressobj(size=size)
    block = bytes(1 << 20)
    return b"".join(stream.compress(block) for _ in range(size >> 20)) + stream.flush()

bomb = zeros_zstd(2 << 30)  # 2 GiB of zeros: ~64 KB
jpeg = bytes.fromhex(sys.argv[1])
cases = {
    "zstd claiming 2 GiB": lambda: decompress(bomb, "zstd", 2 << 30, budget_for(len(bomb)), "chunk 0"),
    "zstd lying (claims 1 MiB)": lambda: decompress(bomb, "zstd", 1 << 20, budget_for(len(bomb)), "chunk 0"),
    "lz4 lying": lambda: decompress(lz4.frame.compress(bytes(128 << 20)), "lz4", 4096, 1 << 30, "chunk 1"),
    "dotted key": lambda: parse_toml("a" + ".a" * 20000 + " = 1", "c.toml"),
    "toml 3000 deep": lambda: parse_toml("x = " + "[" * 3000 + "]" * 3000, "c.toml"),
    "json 100k deep": lambda: parse_json("[" * 100000 + "]" * 100000, "t.json"),
    "jpeg 30000x30000": lambda: check_image(jpeg, "frame"),
    "raw 14000x14000": lambda: check_raw_image(14000, 14000, 28000, 2, 15000, "depth", max_pixels=1 << 40),
    "/dev/zero": lambda: read_bytes("/dev/zero", 1 << 40, "config"),
    "/dev/zero toml": lambda: load_toml("/dev/zero", CONFIG_TOML),
}
clean = []
for name, case in cases.items():
    try:
        case()
    except UntrustedInput as e:
        clean.append(name)
        print(f"{name}: {e}")
try:  # the control: the cap is real, the naive call cannot allocate what the header claims
    zstandard.ZstdDecompressor().decompress(bomb)
    naive = "decoded"
except (MemoryError, zstandard.ZstdError) as e:
    naive = type(e).__name__
# VmHWM: this process's own high-water mark (ru_maxrss keeps the forking parent's across exec)
peak = next(int(l.split()[1]) for l in open("/proc/self/status") if l.startswith("VmHWM:")) / 1024
print(json.dumps({"clean": clean, "cases": len(cases), "naive": naive, "peak_mb": peak}))
'''


def test_hostile_inputs_fail_cleanly_under_a_512_mb_cap() -> None:
    jpeg = _claim(_jpeg(64, 48), 30000, 30000)
    env = dict(os.environ, PYTHONPATH=str(ROOT), OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1")
    out = subprocess.run([sys.executable, "-c", _CAPPED, jpeg.hex()], capture_output=True, text=True,
                         timeout=180, env=env, cwd=ROOT)
    assert out.returncode == 0 and "Traceback" not in out.stderr, out.stderr[-3000:]
    report = json.loads(out.stdout.splitlines()[-1])
    assert len(report["clean"]) == report["cases"] == 10, out.stdout
    assert report["naive"] in ("MemoryError", "ZstdError"), report  # without the limits: no memory
    assert report["peak_mb"] < 512, report
    for line in out.stdout.splitlines()[:-1]:
        assert len(line) < 300, line


# ---------------------------------------------------------------- generated inputs: only one error type

_TRICKY = ["[", "]", "{", "}", ",", ".", "=", "#", "'", '"', "\\", "\n", "a.b", "ü", " "]


def _toml_string(rng: np.random.Generator) -> str:
    text = "".join(rng.choice(_TRICKY) for _ in range(int(rng.integers(0, 8))))
    style = int(rng.integers(0, 4))
    if style == 0:
        return json.dumps(text.replace("\n", " "))  # a basic string (JSON escapes are TOML escapes here)
    if style == 1 and "'" not in text and "\n" not in text:
        return f"'{text}'"
    if style == 2 and "'''" not in text and not text.endswith("'"):
        return f"'''{text}'''"
    body = text.replace("\\", "\\\\").replace('"', '\\"')
    return f'"""{body}"""'


def _toml_value(rng: np.random.Generator, depth: int) -> str:
    kind = int(rng.integers(0, 5 if depth < 6 else 3))
    if kind == 0:
        return str(int(rng.integers(-1000, 1000)))
    if kind == 1:
        return repr(float(rng.normal()))
    if kind == 2:
        return _toml_string(rng)
    items = [_toml_value(rng, depth + 1) for _ in range(int(rng.integers(0, 4)))]
    if kind == 3:
        return "[" + ", ".join(items) + "]"
    return "{" + ", ".join(f"{_toml_key(rng)}.i{i} = {v}" for i, v in enumerate(items)) + "}"


def _toml_key(rng: np.random.Generator) -> str:
    return ".".join(rng.choice(["a", "b_c", '"q.[x]"', "'l.{y}'"]) for _ in range(int(rng.integers(1, 4))))


def test_generated_toml_the_scan_never_counts_lower_than_the_parser() -> None:
    rng = np.random.default_rng(7)
    for case in range(400):
        lines = ["# comment [[[ {{ . . ' \""] + [f"{_toml_key(rng)}.k{k} = {_toml_value(rng, 1)}" for k in range(4)]
        if case % 3 == 0:
            lines.insert(0, f"[{_toml_key(rng)}]")
        text = "\n".join(lines) + "\n"
        parsed = tomllib.loads(text)  # the generator writes valid TOML
        depth, parts, items = toml_shape(text)
        assert (depth + 2) * parts + depth >= _true_depth(parsed), text  # dotted keys add up at every level
        assert parse_toml(text, "gen.toml", L.InputLimits(max_bytes=1 << 20, max_depth=64, max_key_parts=64)) == parsed


def test_mutated_inputs_give_only_untrusted_input() -> None:
    """A few thousand byte-level mutations of real TOML, JSON, JPEG, PNG, zstd and lz4: every parser
    either succeeds or raises UntrustedInput — never another exception."""
    import lz4.frame
    import zstandard

    rng = np.random.default_rng(11)
    raw = (ROOT / "configs" / "demo.toml").read_bytes()
    seeds: dict[str, bytes] = {
        "toml": raw, "json": json.dumps({"a": [1, 2.5, {"b": "[x]"}], "c": None}).encode(),
        "jpeg": _jpeg(40, 30), "png": _png(40, 30),
        "zstd": zstandard.ZstdCompressor().compress(raw), "lz4": lz4.frame.compress(raw),
    }
    for kind, seed in seeds.items():
        for _ in range(300):
            data = bytearray(seed)
            for _ in range(int(rng.integers(1, 6))):
                at = int(rng.integers(0, len(data) + 1))
                op = int(rng.integers(0, 3))
                if op == 0 and at < len(data):
                    data[at] = int(rng.integers(0, 256))
                elif op < 2:
                    del data[at:at + int(rng.integers(1, 40))]
                else:
                    data[at:at] = bytes(rng.choice(list(b"[]{}\"'\\.=,#\n\xff\x00"), int(rng.integers(1, 30))))
            blob = bytes(data)
            try:
                if kind == "toml":
                    parse_toml(blob.decode("utf-8", "replace"), "m.toml")
                elif kind == "json":
                    parse_json(blob, "m.json")
                elif kind in ("jpeg", "png"):
                    check_image(blob, "m")
                else:
                    decompress(blob, kind, len(raw), budget_for(len(blob)), "m")
            except UntrustedInput as e:
                assert "\n" not in str(e)
