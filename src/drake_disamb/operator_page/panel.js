// The operator panel: OperatorPanel.render draws one panel state (what systems/panel.py publishes)
// into an element; the live page (operator.html) and a saved recording's replay (replay.py) both use
// it, so a reviewer sees what the person saw. On the live page this file also wires the page to its
// server (drake_disamb/operator_page/server.py): the panel and the session's screens arrive as
// Server-Sent Events; keys, the gamepad and a heartbeat go back as POST /input.
"use strict";

const OperatorPanel = (() => {
  function el(tag, cls, text) {
    const node = document.createElement(tag);
    if (cls) node.className = cls;
    if (text !== undefined && text !== null) node.textContent = String(text);
    return node;
  }

  function swatch(color) {
    const s = el("span", "op-swatch");
    s.style.background = color || "#fff";
    return s;
  }

  function bar(cls, percent) {
    const outer = el("div", cls);
    const inner = el("div");
    inner.style.width = Math.max(0, Math.min(100, percent)) + "%";
    outer.append(inner);
    return outer;
  }

  function section(id, label) {
    const s = el("section", "op-section");
    s.id = id;
    if (label) s.append(el("p", "op-label", label));
    return s;
  }

  function guessSection(panel) {
    const s = section("op-guess", "The robot thinks you are going to");
    const g = panel.guess;
    const line = el("div", "op-guess");
    if (g) {
      line.append(swatch(g.color), el("span", null, `the ${g.name}: ${g.percent} %`));
    } else {
      line.append(el("span", null, "no goal stands out yet"));
    }
    s.append(line);
    const list = el("ul", "op-goals");
    for (const goal of panel.goals || []) {
      const row = el("li", "op-goal" + (goal.leading ? " leading" : ""));
      row.append(swatch(goal.color), el("span", null, goal.name), el("span", "op-pct", `${goal.percent} %`),
        bar("op-minibar", goal.percent));
      list.append(row);
    }
    s.append(list);
    return s;
  }

  function statusSection(panel) {
    const status = panel.status || {};
    const s = el("div", "op-status-wrap");
    s.id = "op-status-section";
    if (!status.kind) return s;
    const box = el("div", "op-status " + status.kind);
    box.id = "op-status";
    box.append(el("div", null, status.text));
    if (status.detail) box.append(el("div", "op-small", status.detail));
    s.append(box);
    return s;
  }

  function modeSection(panel, onKey, status) {
    const s = section("op-mode-section", "Mode");
    const mode = panel.mode || {};
    s.append(el("div", "op-mode", mode.title || ""));
    if (mode.detail) s.append(el("div", "op-small", mode.detail));
    s.append(status);
    const table = el("table", "op-keys");
    table.id = "op-keys";
    for (const row of panel.keys || []) {
      const tr = el("tr");
      const keyCell = el("td");
      if (onKey && row.codes && row.codes.length) {
        const b = el("button", null, row.keys);
        b.type = "button";
        b.addEventListener("click", () => onKey(row.codes[row.codes.length - 1]));
        keyCell.append(b);
      } else {
        keyCell.append(el("b", null, row.keys));
      }
      tr.append(keyCell, el("td", null, row.action));
      table.append(tr);
    }
    s.append(table);
    return s;
  }

  function shareSection(panel) {
    const s = section("op-share", "The robot's share of the motion");
    const share = panel.share || 0;
    s.append(el("div", "op-share-text", `${share} %`));
    s.append(bar("op-bar", share));
    return s;
  }

  // Draw one panel state into `root`; `onKey(code)` (optional) makes the key rows clickable.
  function render(root, panel, onKey) {
    root.replaceChildren();
    if (!panel) {
      root.append(el("p", "muted", "Waiting for the robot\u2026"));
      return;
    }
    if (panel.title) root.append(el("p", "op-title", panel.title + (panel.stage ? ` \u00b7 ${panel.stage}` : "")));
    root.append(modeSection(panel, onKey, statusSection(panel)), guessSection(panel), shareSection(panel));
  }

  return { render, el };
})();

(() => {
  const settings = window.OPERATOR_PAGE;
  if (!settings || !settings.live) return;
  const el = OperatorPanel.el;
  const pageId = Math.random().toString(36).slice(2, 12) + Date.now().toString(36);
  const panelRoot = document.getElementById("panel");
  const screenRoot = document.getElementById("screen");
  const scene = document.getElementById("scene");
  const sceneNote = document.getElementById("scene-note");
  const offline = document.getElementById("offline");
  let message = { codes: [], actions: {}, heartbeat: 0.1 };
  let screenId = null;
  let statusSeen = "";
  const received = []; // [seq, the state's wall time, when the page drew it, when it arrived] (s since the epoch)
  const events = []; // what the person did and saw, with when (s since the epoch)
  const wallNow = () => (performance.timeOrigin + performance.now()) / 1000;
  const note = (event) => {
    events.push(Object.assign({ wall: wallNow() }, event));
    if (events.length > 10000) events.splice(0, 5000);
  };
  window.operatorPage = { received, events, pageId, lastMessage: null };

  function post(body) {
    body.page = pageId;
    return fetch("/input", {
      method: "POST", headers: { "Content-Type": "application/json" }, body: JSON.stringify(body), keepalive: true,
    }).catch(() => {});
  }

  function press(code) {
    post({ type: "down", code }).then(() => post({ type: "up", code }));
  }

  if (settings.meshcatPort) {
    // The scene from another site than the page's (localhost and 127.0.0.1 are the same machine but
    // two sites): the browser runs it in its own process, so drawing the scene never delays the panel.
    const swap = { localhost: "127.0.0.1", "127.0.0.1": "localhost" };
    const host = swap[location.hostname] || location.hostname;
    scene.src = `${location.protocol}//${host}:${settings.meshcatPort}/`;
    // Keys go to the page, not to the scene: when the pointer leaves the scene the panel takes the focus back.
    scene.addEventListener("mouseleave", () => panelRoot.focus());
  }
  panelRoot.addEventListener("mousedown", () => panelRoot.focus());

  function renderScreen(screen) {
    if (!screen) {
      screenRoot.hidden = true;
      screenRoot.replaceChildren();
      screenId = null;
      return;
    }
    if (screen.id === screenId) { // the same screen: keep what the person typed, say what is wrong
      const error = document.getElementById("op-screen-error");
      error.textContent = screen.error || "";
      error.hidden = !screen.error;
      return;
    }
    screenId = screen.id;
    screenRoot.replaceChildren();
    const box = el("div", "op-screen");
    box.id = "op-screen";
    box.append(el("h1", null, screen.title || ""));
    const error = el("p", "op-error", screen.error || "");
    error.id = "op-screen-error";
    error.hidden = !screen.error;
    box.append(error);
    for (const line of screen.lines || []) box.append(el("p", null, line));
    if (screen.kind === "survey") {
      box.append(surveyForm(screen));
    } else if (screen.button && screen.action) {
      const go = el("button", "op-go", screen.button);
      go.type = "button";
      go.id = "op-go";
      go.addEventListener("click", () => post({ type: "action", name: screen.action }));
      box.append(go);
    }
    screenRoot.append(box);
    screenRoot.hidden = false;
  }

  function select(name, choices) {
    const s = el("select");
    s.name = name;
    s.append(el("option", null, "\u2014"));
    s.firstChild.value = "";
    for (const [value, label] of choices) {
      const o = el("option", null, label);
      o.value = String(value);
      s.append(o);
    }
    return s;
  }

  function surveyForm(screen) {
    const form = el("form");
    form.id = "op-survey";
    for (const q of screen.questions || []) {
      form.append(el("p", null, `${q.id}. ${q.text}`));
      const table = el("table");
      if (q.kind === "likert") {
        const scale = [];
        for (let v = 1; v <= 7; v++) scale.push([v, `${v}${q.scale && q.scale[v] ? " \u2013 " + q.scale[v] : ""}`]);
        for (const item of q.items) {
          const tr = el("tr");
          tr.append(el("td", null, item.label));
          const td = el("td");
          td.append(select(`${q.id}|${item.key}`, scale));
          tr.append(td);
          table.append(tr);
        }
      } else {
        const tr = el("tr");
        const td = el("td");
        td.append(select(q.id, q.options.map((o) => [o.value, o.label])));
        tr.append(td);
        table.append(tr);
      }
      form.append(table);
    }
    const go = el("button", "op-go", screen.button || "Send");
    go.type = "submit";
    go.id = "op-go";
    form.append(go);
    form.addEventListener("submit", (event) => {
      event.preventDefault();
      const answers = {};
      for (const s of form.querySelectorAll("select")) {
        const [id, key] = s.name.split("|");
        const value = s.value === "" ? null : s.value;
        if (key === undefined) answers[id] = value;
        else (answers[id] = answers[id] || {})[key] = value;
      }
      post({ type: "survey", answers });
    });
    return form;
  }

  function apply(msg, arrived) {
    message = msg;
    window.operatorPage.lastMessage = msg;
    OperatorPanel.render(panelRoot, msg.panel, msg.screen ? null : press);
    renderScreen(msg.screen);
    const status = msg.panel && msg.panel.status ? `${msg.panel.status.kind}|${msg.panel.status.text}` : "";
    if (status !== statusSeen) {
      statusSeen = status;
      note({ kind: "status", status: msg.panel ? msg.panel.status : null });
    }
    if (msg.panel && msg.panel.wall !== undefined) {
      const seq = msg.seq;
      const wall = msg.panel.wall;
      requestAnimationFrame(() => {
        received.push([seq, wall, wallNow(), arrived]);
        if (received.length > 20000) received.splice(0, 10000);
      });
    }
  }

  const stream = new EventSource("/events");
  stream.onmessage = (event) => {
    const arrived = wallNow();
    offline.hidden = true;
    apply(JSON.parse(event.data), arrived);
  };
  stream.onerror = () => { offline.hidden = false; };

  function inForm(event) {
    return event.target && event.target.closest && event.target.closest("#op-survey");
  }

  document.addEventListener("keydown", (event) => {
    if (inForm(event)) return;
    const code = event.code;
    const action = message.actions && message.actions[code === "NumpadEnter" ? "Enter" : code];
    if (action) {
      event.preventDefault();
      if (!event.repeat) post({ type: "action", name: action });
      return;
    }
    if (message.codes && message.codes.includes(code)) {
      event.preventDefault();
      if (!event.repeat) {
        note({ kind: "key", code });
        post({ type: "down", code }); // a held key repeats on the server, not here
      }
    }
  });
  document.addEventListener("keyup", (event) => {
    if (inForm(event)) return;
    if (message.codes && message.codes.includes(event.code)) {
      event.preventDefault();
      post({ type: "up", code: event.code });
    }
  });
  // A page that loses the focus (or is hidden) lets go of every key: it would never see their release.
  window.addEventListener("blur", () => {
    post({ type: "release" });
    setTimeout(() => { sceneNote.hidden = document.activeElement !== scene; }, 0);
  });
  window.addEventListener("focus", () => { sceneNote.hidden = true; });
  panelRoot.addEventListener("focus", () => { sceneNote.hidden = true; });
  document.addEventListener("visibilitychange", () => { if (document.hidden) post({ type: "release" }); });

  function gamepad() {
    if (!navigator.getGamepads) return null;
    for (const pad of navigator.getGamepads()) {
      if (pad && pad.connected) {
        return {
          index: pad.index,
          button_values: pad.buttons.map((b) => Math.round(b.value * 100) / 100),
          axes: pad.axes.map((a) => Math.round(a * 100) / 100),
        };
      }
    }
    return null;
  }
  setInterval(() => post({ type: "alive", gamepad: gamepad() }), 1000 * (message.heartbeat || 0.1));
  post({ type: "alive", gamepad: gamepad() });
  panelRoot.focus();
})();
