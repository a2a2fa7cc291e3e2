"""The keys pressed in the renderer's window, as canonical combination names ("f1", "ctrl+shift+q";
modifiers in the order ctrl, shift, alt, super), for the composition root to act on.

In kiosk mode every key press is consumed here, so pyglet's own handler never sees Esc (which
would close the window); only the configured exit combination closes it. In a desktop window Esc
still closes it.
"""

from __future__ import annotations

from typing import Any

_MODIFIER_KEYS = {"lshift", "rshift", "lctrl", "rctrl", "lalt", "ralt", "lmeta", "rmeta", "lwindows",
                  "rwindows", "lcommand", "rcommand", "loption", "roption", "capslock", "numlock",
                  "scrolllock", "function", "mode_switch"}


def combo_name(symbol: int, modifiers: int) -> str | None:
    """"ctrl+shift+q" for a pyglet key press (None for a modifier key pressed alone)."""
    from pyglet.window import key

    name = key.symbol_string(symbol).lower().lstrip("_")
    if name in _MODIFIER_KEYS:
        return None
    mods = [m for m, bits in (("ctrl", key.MOD_CTRL), ("shift", key.MOD_SHIFT), ("alt", key.MOD_ALT),
                              ("super", key.MOD_WINDOWS | key.MOD_COMMAND)) if modifiers & bits]
    return "+".join([*mods, name])


class WindowKeys:
    """Listens to ``window``'s key presses. ``exit_combo`` (canonical name) sets the window's
    ``has_exit``; ``kiosk``: consume every press (Esc does nothing). ``take()`` returns the
    combinations pressed since the last call."""

    def __init__(self, window: Any, exit_combo: str | None, *, kiosk: bool) -> None:
        self.window, self.exit_combo, self.kiosk = window, exit_combo, kiosk
        self._pressed: list[str] = []
        window.push_handlers(on_key_press=self._on_key_press)

    def _on_key_press(self, symbol: int, modifiers: int) -> bool | None:
        name = combo_name(symbol, modifiers)
        if name is not None:
            self._pressed.append(name)
            del self._pressed[:-32]  # nobody reads them (headless): keep a few
            if name == self.exit_combo:
                self.window.has_exit = True
                return True
        return True if self.kiosk else None  # True: handled, pyglet's Esc handler is not called

    def take(self) -> tuple[str, ...]:
        out = tuple(self._pressed)
        self._pressed.clear()
        return out
