"""The one set of limits for input from outside (DESIGN.md §7), for every reader and writer.

Readers open regular files only (``open_regular``, ``read_bytes``, ``read_text``), bound TOML/JSON
before parsing (``load_toml``, ``load_json``), check images' declared sizes before decoding
(``check_image``, ``check_raw_image``), decompress within a budget (``decompress``, ``budget_for``),
take numbers finite and in range (``finite``, ``whole``) and time monotone (``Timeline``). Writers
replace only regular files (``write_owned``, ``check_owned``); systemd units quote by systemd's rules (``systemd_*``).
Every refusal is one ``UntrustedInput`` (a ``ValueError``, one line ``SOURCE: PROBLEM``, a user
error). The numbers live in ``sensors.untrusted.limits``. Imports only the standard library.
"""

from sensors.untrusted.compressed import budget_for, decompress
from sensors.untrusted.errors import MissingInput, UntrustedInput, one_line, shorten
from sensors.untrusted.files import decode_text, open_regular, read_bytes, read_text, resolve_within
from sensors.untrusted.images import check_image, check_raw_image, image_size_from_header
from sensors.untrusted.limits import InputLimits
from sensors.untrusted.numbers import Timeline, finite, whole
from sensors.untrusted.structured import load_json, load_toml, parse_json, parse_toml
from sensors.untrusted.systemd import (
    systemd_environment,
    systemd_escape,
    systemd_exec_argument,
    systemd_exec_path,
    systemd_path,
    systemd_text,
    systemd_user,
)
from sensors.untrusted.writes import check_owned, write_owned

__all__ = [
    "InputLimits",
    "MissingInput",
    "Timeline",
    "UntrustedInput",
    "budget_for",
    "check_image",
    "check_owned",
    "check_raw_image",
    "decode_text",
    "decompress",
    "finite",
    "image_size_from_header",
    "load_json",
    "load_toml",
    "one_line",
    "open_regular",
    "parse_json",
    "parse_toml",
    "read_bytes",
    "read_text",
    "resolve_within",
    "shorten",
    "systemd_environment",
    "systemd_escape",
    "systemd_exec_argument",
    "systemd_exec_path",
    "systemd_path",
    "systemd_text",
    "systemd_user",
    "whole",
    "write_owned",
]
