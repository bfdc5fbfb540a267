"""The operator panel in a saved recording: what the person saw, replayed beside the scene.

:func:`add_panel_replay` puts the panel (drawn by the live page's own ``panel.js``) on a Meshcat
``StaticHtml`` page with the panel states the trial published (each with its simulated time ``t``),
and a script that shows, at every frame, the last state at or before the animation's time
(Meshcat's ``viewer.animator.time``, in simulated seconds): scrubbing or replaying the recording
replays the panel with it.
"""

from __future__ import annotations

import json
from collections.abc import Mapping, Sequence
from typing import Any

from drake_disamb.operator_page.model import content
from drake_disamb.operator_page.server import asset_text

__all__ = ["PANEL_LOG_ID", "REPLAY_PANEL_ID", "PanelRecorder", "add_panel_replay"]

PANEL_LOG_ID = "drake-disamb-panel-log"
"""``id`` of the ``<script type="application/json">`` holding the panel states in a recording."""

REPLAY_PANEL_ID = "drake-disamb-panel"
"""``id`` of the panel's ``<aside>`` in a recording."""

_REPLAY_CSS = f"""
#{REPLAY_PANEL_ID} {{ position: fixed; right: 0; top: 24px; bottom: 0; width: 32vw; min-width: 360px;
  max-width: 560px; overflow-y: auto; box-sizing: border-box; padding: 12px 16px; z-index: 9;
  background: rgba(255, 255, 255, 0.94); border-left: 3px solid #000; color: #000;
  font-family: "DejaVu Sans", Verdana, sans-serif; }}
.dg.ac {{ z-index: 20 !important; }}
"""
"""The panel beside the scene, below Meshcat's "Open Controls" (the recording's play, pause and
time), which open over it."""

_REPLAY_SCRIPT = f"""
(() => {{
  const log = JSON.parse(document.getElementById("{PANEL_LOG_ID}").textContent);
  const root = document.getElementById("{REPLAY_PANEL_ID}");
  let shown = null;
  function now() {{
    try {{ return viewer.animator.time || 0; }} catch (e) {{ return 0; }}
  }}
  function at(t) {{
    let lo = 0, hi = log.length - 1, found = log.length ? 0 : -1;
    while (lo <= hi) {{
      const mid = (lo + hi) >> 1;
      if (log[mid].t <= t + 1e-9) {{ found = mid; lo = mid + 1; }} else {{ hi = mid - 1; }}
    }}
    return found;
  }}
  function frame() {{
    const i = at(now());
    if (i !== shown) {{ OperatorPanel.render(root, i >= 0 ? log[i] : null); shown = i; }}
    requestAnimationFrame(frame);
  }}
  requestAnimationFrame(frame);
}})();
"""


class PanelRecorder:
    """The panel states of one trial for its recording: each state that says something new (its
    :func:`content` differs from the last one's), with its simulated time ``t``.

    A sink of :class:`~drake_disamb.systems.panel.PanelVisualizer`, as Meshcat keeps the scene's
    recording (:attr:`log`, in time order: a state published at an earlier time than the last one,
    a new simulation, starts the log again)."""

    def __init__(self) -> None:
        self.log: list[dict[str, Any]] = []
        self._last: dict[str, Any] | None = None

    def show(self, panel: Mapping[str, Any]) -> None:
        said = content(panel)
        if self.log and panel["t"] < self.log[-1]["t"]:
            self.log.clear()
            self._last = None
        if said != self._last:
            self.log.append(dict(panel))
            self._last = said


def _script_json(data: Any) -> str:
    """``data`` as JSON safe inside a ``<script>`` element."""
    return json.dumps(data, allow_nan=False, separators=(",", ":")).replace("</", "<\\/")


def add_panel_replay(page: str, log: Sequence[Mapping[str, Any]]) -> str:
    """``page`` (a Meshcat ``StaticHtml``) with the operator panel replaying ``log`` (the panel
    states, each with its simulated time ``t``, in time order) before ``</body>``.

    Raises:
        ValueError: ``page`` has no ``</body>``, or a state has no finite ``t``.
    """
    at = page.rfind("</body>")
    if at < 0:
        raise ValueError("page: expected an HTML page with a </body> tag")
    for i, state in enumerate(log):
        t = state.get("t")
        if not isinstance(t, int | float) or t != t or t in (float("inf"), float("-inf")):
            raise ValueError(f"log[{i}].t: expected the state's simulated time, got {t!r}")
    insert = (
        f"<style>{asset_text('panel.css')}{_REPLAY_CSS}</style>\n"
        f'<aside id="{REPLAY_PANEL_ID}" class="op-panel"></aside>\n'
        f'<script type="application/json" id="{PANEL_LOG_ID}">{_script_json(list(log))}</script>\n'
        f"<script>{asset_text('panel.js')}</script>\n<script>{_REPLAY_SCRIPT}</script>\n"
    )
    return page[:at] + insert + page[at:]
