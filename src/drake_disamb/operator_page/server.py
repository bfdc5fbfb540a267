"""The operator page's server: one small HTTP server on this machine, in a thread of the command.

:class:`OperatorPage` serves one page (``operator.html``): the Meshcat scene in an iframe and the
panel beside it (``panel.js``, ``panel.css``). The page and the server talk in two directions:

- to the page, Server-Sent Events (``GET /events``): every panel state the diagram publishes
  (:meth:`OperatorPage.show`), the session's screen (:meth:`OperatorPage.set_screen`) and the keys
  the page should capture, as one JSON message each time one of them changes (``GET /state``
  gives the latest, for scripts);
- from the page, ``POST /input`` (JSON): key presses and releases captured on the page, the
  gamepad (the browser's Gamepad API) and a heartbeat every :data:`HEARTBEAT` seconds, the
  session's actions (Enter to start, the experimenter's key) and the questionnaire's answers.

It offers the controls part of Meshcat's API that the live input and the page's deadman use
(``AddButton``, ``GetButtonClicks``, ``AddSlider``, ``GetSliderValue``, ``SetSliderValue``,
``GetGamepad``, ``GetNumActiveConnections``, ...), so
:class:`~drake_disamb.interfaces.live.MeshcatLiveInput` and
:class:`~drake_disamb.interfaces.deadman.PageDeadman` read this page as they read Meshcat's. A key
press is a button click; a key registered with :meth:`OperatorPage.repeat_while_held` (the drive
keys) also counts one click every :data:`HOLD_REPEAT` seconds while it is held, from the press to
its release (the browser's own auto-repeats are ignored: a held key drives continuously in every
browser, and only as long as it is held). A page that loses the focus, is hidden, or whose
heartbeat stops for :data:`PAGE_STALE` seconds has released every key it held; only pages whose
heartbeat is fresh count as connected.

It listens on the host it is given (``--meshcat-host``: localhost unless the user asks for
more). A ``POST`` must be JSON (a cross-site form cannot send one without the browser asking
first, which this server never answers) and, when the browser says where it comes from
(``Origin``), come from this page.
"""

from __future__ import annotations

import json
import math
import queue
import socket
import threading
import time
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from importlib import resources
from typing import Any
from urllib.parse import urlsplit

from drake_disamb.operator_page.model import content

__all__ = [
    "DEFAULT_PORT",
    "HEARTBEAT",
    "HOLD_REPEAT",
    "PAGE_STALE",
    "Gamepad",
    "OperatorPage",
    "asset_text",
]

DEFAULT_PORT = 7100
"""The first port tried (the next free one is taken, as Meshcat does from 7000)."""

PORT_TRIES = 100
"""Ports tried from the first one."""

HEARTBEAT = 0.1
"""Seconds between two heartbeats of the page."""

PAGE_STALE = 0.3
"""Seconds without a heartbeat after which a page is gone (its keys released, not connected)."""

HOLD_REPEAT = 0.2
"""Seconds between the clicks a held repeating key counts (shorter than the live input's
``hold_time``, so that the drive never lapses while the key is held)."""

MAX_BODY = 65536
"""Largest ``POST`` body (bytes) the server reads."""

MAX_CODE = 32
"""Longest key code (characters) the server takes."""

ASSETS = {"/panel.js": "text/javascript", "/panel.css": "text/css"}


def asset_text(name: str) -> str:
    """The text of one of the page's files (``operator.html``, ``panel.js``, ``panel.css``)."""
    return resources.files("drake_disamb.operator_page").joinpath(name).read_text(encoding="utf-8")


@dataclass(frozen=True)
class Gamepad:
    """A gamepad as the page reports it (the shape of Meshcat's ``GetGamepad()``).

    Attributes:
        index: The browser's index of the gamepad, or ``None`` when none is connected.
        button_values: Each button's value in ``[0, 1]``.
        axes: Each axis in ``[-1, 1]``.
    """

    index: int | None = None
    button_values: tuple[float, ...] = ()
    axes: tuple[float, ...] = ()


@dataclass
class _Button:
    keycode: str
    clicks: int = 0


@dataclass
class _Slider:
    low: float
    high: float
    step: float
    value: float
    decrement: str
    increment: str


@dataclass
class _Page:
    seen: float
    held: dict[str, float] = field(default_factory=dict)
    """Repeating key code -> when it was pressed (``time.monotonic``)."""


def _clamped(values: Any, low: float, high: float, most: int = 32) -> tuple[float, ...]:
    if not isinstance(values, list):
        return ()
    out = []
    for v in values[:most]:
        x = float(v) if isinstance(v, int | float) and not isinstance(v, bool) else 0.0
        out.append(min(high, max(low, x)) if math.isfinite(x) else 0.0)
    return tuple(out)


class OperatorPage:
    """The operator page's HTTP server (module docstring), started at construction.

    Args:
        host: Where to listen (``localhost``; ``*`` or ``0.0.0.0`` for every interface).
        port: The port, or ``None``: the first free one from :data:`DEFAULT_PORT`.
        meshcat_port: The port of the Meshcat server whose scene the page shows (the page opens
            it on the host the browser reached this page at), or ``None`` for no scene.
        title: The page's title.

    Raises:
        ValueError: The port is taken, or nothing could listen on ``host`` (names them).
    """

    def __init__(
        self,
        host: str = "localhost",
        port: int | None = None,
        meshcat_port: int | None = None,
        title: str = "",
    ) -> None:
        self.host = host
        self.title = title or "drake-disamb operator page"
        self.meshcat_port = meshcat_port
        self._cond = threading.Condition()
        self._closed = False
        self._seq = 0
        self._panel: dict[str, Any] | None = None
        self._screen: dict[str, Any] | None = None
        self._actions: dict[str, str] = {}
        self._buttons: dict[str, _Button] = {}
        self._sliders: dict[str, _Slider] = {}
        self._repeat: set[str] = set()
        self._pages: dict[str, _Page] = {}
        self._gamepad = Gamepad()
        self._inbox: queue.Queue[tuple[str, Any]] = queue.Queue()
        self._server = self._listen(host, port)
        self._thread = threading.Thread(target=self._server.serve_forever, name="operator-page", daemon=True)
        self._thread.start()

    # -- the server ---------------------------------------------------------------------------------

    def _listen(self, host: str, port: int | None) -> ThreadingHTTPServer:
        bind = "" if host in ("*", "0.0.0.0", "::") else host
        family = socket.AF_INET6 if ":" in bind or host == "::" else socket.AF_INET
        handler = type("Handler", (_Handler,), {"page": self})
        server_class = type(
            "Server", (ThreadingHTTPServer,), {"address_family": family, "daemon_threads": True}
        )
        ports = [port] if port is not None else range(DEFAULT_PORT, DEFAULT_PORT + PORT_TRIES)
        last: OSError | None = None
        for p in ports:
            try:
                return server_class((bind, p), handler)
            except OSError as exc:
                last = exc
        if port is not None:
            raise ValueError(f"--page-port: port {port} on {host} is taken or refused ({last})")
        last_port = DEFAULT_PORT + PORT_TRIES - 1
        raise ValueError(f"operator page: no free port in {DEFAULT_PORT}..{last_port} on {host} ({last})")

    def port(self) -> int:
        """The port the page is served on."""
        return int(self._server.server_address[1])

    def web_url(self) -> str:
        """The page's address, as this machine opens it."""
        shown = "localhost" if self.host in ("*", "0.0.0.0", "::") else self.host
        if ":" in shown:
            shown = f"[{shown}]"
        return f"http://{shown}:{self.port()}/"

    def close(self) -> None:
        """Stop serving (the open event streams end; idempotent)."""
        with self._cond:
            if self._closed:
                return
            self._closed = True
            self._cond.notify_all()
        self._server.shutdown()
        self._server.server_close()

    def __enter__(self) -> OperatorPage:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # -- what the page shows --------------------------------------------------------------------------

    def show(self, panel: Mapping[str, Any] | None) -> None:
        """Show a panel state (JSON-ready; the panel system's) on every open page; a state that says
        what the shown one says (the same but for its time stamps ``t`` and ``wall``) is not sent."""
        with self._cond:
            same = panel is not None and self._panel is not None and content(panel) == content(self._panel)
            if same:
                return
            self._panel = None if panel is None else dict(panel)
            self._changed()

    def set_screen(self, screen: Mapping[str, Any] | None, actions: Mapping[str, str] | None = None) -> None:
        """Show a screen over the panel (a session's instructions, rest, questionnaire; ``None``:
        none) and bind ``actions`` (key code -> action name, e.g. ``{"Enter": "start"}``): a press of
        one of those keys, or a click on the screen's button, puts the action in the inbox
        (:meth:`wait_action`)."""
        with self._cond:
            self._screen = None if screen is None else dict(screen)
            self._actions = dict(actions or {})
            self._changed()

    def message(self) -> dict[str, Any]:
        """What the page is sent now (``GET /state``): the panel, the screen, the keys it captures."""
        with self._cond:
            return self._message()

    def _message(self) -> dict[str, Any]:
        codes = {b.keycode for b in self._buttons.values() if b.keycode}
        for s in self._sliders.values():
            codes.update(c for c in (s.decrement, s.increment) if c)
        return {
            "seq": self._seq,
            "panel": self._panel,
            "screen": self._screen,
            "codes": sorted(codes),
            "actions": dict(self._actions),
            "heartbeat": HEARTBEAT,
        }

    def _changed(self) -> None:
        self._seq += 1
        self._cond.notify_all()

    def _wait_message(self, seq: int, timeout: float) -> dict[str, Any] | None:
        """The next message after ``seq`` within ``timeout`` s (``None``: none; closed: raises)."""
        with self._cond:
            self._cond.wait_for(lambda: self._closed or self._seq != seq, timeout)
            if self._closed:
                raise ConnectionAbortedError("the operator page is closed")
            return self._message() if self._seq != seq else None

    # -- the controls (the part of Meshcat's API the live input and the deadman use) --------------

    def AddButton(self, name: str, keycode: str = "") -> None:
        """Add a button (a key ``keycode`` clicks it), or reset an existing one's clicks."""
        with self._cond:
            self._buttons[name] = _Button(keycode)
            self._changed()

    def DeleteButton(self, name: str, strict: bool = True) -> bool:
        """Delete a button (``strict``: a missing one raises ``RuntimeError``, as Meshcat's)."""
        with self._cond:
            if self._buttons.pop(name, None) is None:
                if strict:
                    raise RuntimeError(f"operator page: no button named {name!r}")
                return False
            self._changed()
            return True

    def GetButtonClicks(self, name: str) -> int:
        """The button's clicks since it was added: its key's presses, and for a repeating key one
        more every :data:`HOLD_REPEAT` seconds it has been held."""
        now = time.monotonic()
        with self._cond:
            self._expire(now)
            button = self._buttons.get(name)
            if button is None:
                raise RuntimeError(f"operator page: no button named {name!r}")
            held = sum(
                self._repeats(page.held[button.keycode], now)
                for page in self._pages.values()
                if button.keycode in page.held
            )
            return button.clicks + held

    def GetButtonNames(self) -> list[str]:
        with self._cond:
            return list(self._buttons)

    def AddSlider(
        self,
        name: str,
        min: float,  # noqa: A002 (Meshcat's argument names)
        max: float,  # noqa: A002
        step: float,
        value: float,
        decrement_keycode: str = "",
        increment_keycode: str = "",
    ) -> float:
        """Add a slider in ``[min, max]`` stepped by its two keys; returns its value."""
        with self._cond:
            slider = _Slider(
                float(min), float(max), float(step), float(value), decrement_keycode, increment_keycode
            )
            slider.value = self._clip(slider, slider.value)
            self._sliders[name] = slider
            self._changed()
            return slider.value

    def DeleteSlider(self, name: str, strict: bool = True) -> bool:
        with self._cond:
            if self._sliders.pop(name, None) is None:
                if strict:
                    raise RuntimeError(f"operator page: no slider named {name!r}")
                return False
            self._changed()
            return True

    def GetSliderValue(self, name: str) -> float:
        with self._cond:
            slider = self._sliders.get(name)
            if slider is None:
                raise RuntimeError(f"operator page: no slider named {name!r}")
            return slider.value

    def SetSliderValue(self, name: str, value: float) -> float:
        with self._cond:
            slider = self._sliders.get(name)
            if slider is None:
                raise RuntimeError(f"operator page: no slider named {name!r}")
            slider.value = self._clip(slider, float(value))
            return slider.value

    def GetSliderNames(self) -> list[str]:
        with self._cond:
            return list(self._sliders)

    def GetGamepad(self) -> Gamepad:
        """The gamepad of the page that last reported one (``index`` None: none, or no page)."""
        with self._cond:
            self._expire(time.monotonic())
            return self._gamepad

    def GetNumActiveConnections(self) -> int:
        """Pages whose heartbeat is fresh (heard within :data:`PAGE_STALE` seconds)."""
        with self._cond:
            self._expire(time.monotonic())
            return len(self._pages)

    def reset_controls(self) -> None:
        """Every button's clicks back to 0, every held key released and every slider at 0 (or the
        nearest value it takes): a new trial's live input starts from a page at rest."""
        with self._cond:
            for button in self._buttons.values():
                button.clicks = 0
            for page in self._pages.values():
                page.held.clear()
            for slider in self._sliders.values():
                slider.value = self._clip(slider, 0.0)

    def repeat_while_held(self, keycodes: Iterable[str]) -> None:
        """Make these keys count a click every :data:`HOLD_REPEAT` seconds while held (the drive
        keys of a switched interface)."""
        with self._cond:
            self._repeat.update(keycodes)

    # -- the session ----------------------------------------------------------------------------------

    def wait_action(self, names: Iterable[str], timeout: float) -> tuple[str, Any] | None:
        """The next action among ``names`` in the inbox (``(name, payload)``), waiting at most
        ``timeout`` seconds; others are dropped (a stale press is not kept for later)."""
        wanted = set(names)
        end = time.monotonic() + timeout
        while True:
            left = end - time.monotonic()
            try:
                name, payload = self._inbox.get(timeout=left) if left > 0 else self._inbox.get_nowait()
            except queue.Empty:
                return None
            if name in wanted:
                return name, payload

    def clear_actions(self) -> None:
        """Drop every action not yet taken."""
        while True:
            try:
                self._inbox.get_nowait()
            except queue.Empty:
                return

    # -- input from the page ----------------------------------------------------------------------------

    def handle(self, data: Any) -> None:
        """One message from a page (``POST /input``).

        Raises:
            ValueError: Not a message this page sends (names what is wrong).
        """
        if not isinstance(data, dict):
            raise ValueError("expected a JSON object")
        kind, page_id = data.get("type"), data.get("page")
        if not isinstance(page_id, str) or not 0 < len(page_id) <= 64:
            raise ValueError("page: expected the page's id")
        now = time.monotonic()
        with self._cond:
            self._expire(now)
            page = self._pages.setdefault(page_id, _Page(now))
            page.seen = now
            if kind == "alive":
                self._gamepad_from(data.get("gamepad"))
            elif kind in ("down", "up"):
                self._key(page, _code(data.get("code")), kind == "down", now)
            elif kind == "release":
                self._release(page, now)
            elif kind == "action":
                name = data.get("name")
                if not isinstance(name, str) or name not in self._actions.values():
                    raise ValueError(
                        f"action: not one of {sorted(set(self._actions.values()))}, got {name!r}"
                    )
                self._inbox.put((name, None))
            elif kind == "survey":
                answers = data.get("answers")
                if not isinstance(answers, dict) or len(answers) > 200:
                    raise ValueError("answers: expected an object")
                self._inbox.put(("survey", answers))
            else:
                raise ValueError(f"type: expected alive, down, up, release, action or survey, got {kind!r}")

    def _key(self, page: _Page, code: str, down: bool, now: float) -> None:
        if not down:
            since = page.held.pop(code, None)
            if since is not None:
                self._credit(code, self._repeats(since, now))
            return
        if code in page.held:
            return  # already held: a repeat
        for button in self._buttons.values():
            if button.keycode == code:
                button.clicks += 1
        for slider in self._sliders.values():
            if code == slider.decrement:
                slider.value = self._clip(slider, slider.value - slider.step)
            elif code == slider.increment:
                slider.value = self._clip(slider, slider.value + slider.step)
        if code in self._repeat:
            page.held[code] = now

    def _release(self, page: _Page, at: float) -> None:
        for code, since in list(page.held.items()):
            self._credit(code, self._repeats(since, at))
        page.held.clear()

    def _credit(self, code: str, clicks: int) -> None:
        for button in self._buttons.values():
            if button.keycode == code:
                button.clicks += clicks

    def _expire(self, now: float) -> None:
        """Forget the pages whose heartbeat stopped: their keys are released as of their last
        heartbeat, and their gamepad with them."""
        for page_id, page in list(self._pages.items()):
            if now - page.seen > PAGE_STALE:
                self._release(page, page.seen)
                del self._pages[page_id]
                if not self._pages:
                    self._gamepad = Gamepad()

    def _gamepad_from(self, pad: Any) -> None:
        if not isinstance(pad, dict) or not isinstance(pad.get("index"), int):
            self._gamepad = Gamepad()
            return
        self._gamepad = Gamepad(
            int(pad["index"]),
            _clamped(pad.get("button_values"), 0.0, 1.0),
            _clamped(pad.get("axes"), -1.0, 1.0),
        )

    @staticmethod
    def _repeats(since: float, now: float) -> int:
        return max(0, int((now - since) / HOLD_REPEAT))

    @staticmethod
    def _clip(slider: _Slider, value: float) -> float:
        return min(slider.high, max(slider.low, value)) if math.isfinite(value) else slider.value

    # -- the page's files -------------------------------------------------------------------------------

    def html(self) -> str:
        """The page, its settings filled in."""
        settings = {"meshcatPort": self.meshcat_port, "live": True}
        page = asset_text("operator.html")
        return page.replace("{{TITLE}}", _escape(self.title)).replace("{{SETTINGS}}", json.dumps(settings))


def _code(value: Any) -> str:
    if not isinstance(value, str) or not 0 < len(value) <= MAX_CODE:
        raise ValueError(f"code: expected a key code, got {value!r}")
    return value


def _escape(text: str) -> str:
    return text.replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;")


class _Handler(BaseHTTPRequestHandler):
    """The page's requests (module docstring)."""

    page: OperatorPage
    server_version = "drake-disamb"

    def log_message(self, format: str, *args: Any) -> None:  # noqa: A002 (the base's signature)
        """Quiet: the command's output is the person's."""

    def _send(self, status: int, body: bytes = b"", kind: str = "text/plain; charset=utf-8") -> None:
        self.send_response(status)
        self.send_header("Content-Type", kind)
        self.send_header("Content-Length", str(len(body)))
        self.send_header("Cache-Control", "no-store")
        self.end_headers()
        if body:
            self.wfile.write(body)

    def do_GET(self) -> None:  # noqa: N802 (the base's name)
        path = urlsplit(self.path).path
        try:
            if path in ("/", "/index.html"):
                self._send(200, self.page.html().encode("utf-8"), "text/html; charset=utf-8")
            elif path in ASSETS:
                self._send(200, asset_text(path[1:]).encode("utf-8"), f"{ASSETS[path]}; charset=utf-8")
            elif path == "/state":
                self._send(200, json.dumps(self.page.message()).encode("utf-8"), "application/json")
            elif path == "/events":
                self._events()
            elif path == "/favicon.ico":
                self._send(204)
            else:
                self._send(404, b"not found")
        except (BrokenPipeError, ConnectionResetError, ConnectionAbortedError):
            pass

    def _events(self) -> None:
        self.send_response(200)
        self.send_header("Content-Type", "text/event-stream")
        self.send_header("Cache-Control", "no-store")
        self.end_headers()
        seq = -1
        while True:
            message = self.page._wait_message(seq, timeout=1.0)
            if message is None:
                self.wfile.write(b": alive\n\n")  # a closed tab shows up as a failed write
                continue
            seq = message["seq"]
            self.wfile.write(b"data: " + json.dumps(message).encode("utf-8") + b"\n\n")

    def do_POST(self) -> None:  # noqa: N802
        if urlsplit(self.path).path != "/input":
            self._send(404, b"not found")
            return
        origin = self.headers.get("Origin")
        if origin is not None and urlsplit(origin).netloc != self.headers.get("Host"):
            self._send(403, b"another site's page may not send input")
            return
        if self.headers.get_content_type() != "application/json":
            self._send(415, b"expected application/json")
            return
        try:
            length = int(self.headers.get("Content-Length", "0"))
        except ValueError:
            length = -1
        if not 0 < length <= MAX_BODY:
            self._send(413, b"expected a body of at most 64 KiB")
            return
        try:
            self.page.handle(json.loads(self.rfile.read(length).decode("utf-8")))
        except (ValueError, UnicodeDecodeError) as exc:
            self._send(400, str(exc).encode("utf-8"))
            return
        self._send(204)
