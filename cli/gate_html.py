"""The gate report as one self-contained HTML page (`certiloop gate --html F`): a summary, every
model with its verdict against its expectation, its obligation tree (collapsible), counterexample
runs plotted as inline SVG, the reasons behind `unknown`, and a search box. No network and no
external assets: the CSS, the script and the plots are inline, so the file can be attached to a CI
run and opened anywhere."""

from __future__ import annotations

from fractions import Fraction
from html import escape

from certiloop.api.gate_run import GateEntry
from certiloop.cli.proof_table import hint, label

MAX_PLOTS = 8  # variables plotted per counterexample (the ones that change, in name order)

CSS = """
body{font:14px/1.45 system-ui,-apple-system,"Segoe UI",sans-serif;margin:0;color:#1d2330;background:#f6f7f9}
header{background:#1d2330;color:#fff;padding:16px 24px}
header h1{margin:0 0 4px;font-size:20px}
main{padding:16px 24px;max-width:1200px}
.summary{display:flex;gap:12px;flex-wrap:wrap;margin:8px 0 16px}
.card{background:#fff;border:1px solid #dde1e8;border-radius:6px;padding:8px 14px}
.card b{font-size:18px;display:block}
#search{width:100%;max-width:480px;padding:8px;font-size:14px;border:1px solid #b8bfcc;border-radius:4px}
table.models{border-collapse:collapse;width:100%;background:#fff;margin:12px 0}
table.models th,table.models td{border-bottom:1px solid #e4e7ec;padding:4px 8px;text-align:left}
.model{background:#fff;border:1px solid #dde1e8;border-radius:6px;margin:10px 0;padding:6px 12px}
.model>summary{cursor:pointer;font-weight:600}
details details{margin-left:18px}
summary{cursor:pointer}
.ob{margin-left:18px;font-family:ui-monospace,Menlo,Consolas,monospace;font-size:12.5px}
.v{display:inline-block;padding:0 6px;border-radius:3px;font-size:12px;font-weight:600;color:#fff}
.v-proved{background:#2e7d32}.v-refuted{background:#c62828}.v-unknown{background:#b26a00}
.v-rule-failed{background:#b26a00}.v-not-supported{background:#6a1b9a}.v-other{background:#546e7a}
.pass{color:#2e7d32;font-weight:700}.fail{color:#c62828;font-weight:700}
.why{background:#fff8e1;border-left:3px solid #b26a00;padding:4px 8px;margin:4px 0;white-space:pre-wrap}
.problem{background:#ffebee;border-left:3px solid #c62828;padding:4px 8px;margin:4px 0}
.plots{display:flex;flex-wrap:wrap;gap:8px}
.plots figure{margin:0;background:#fafbfc;border:1px solid #e4e7ec;border-radius:4px;padding:4px}
.plots figcaption{font-size:12px;font-family:ui-monospace,Menlo,Consolas,monospace}
.trace{font-family:ui-monospace,Menlo,Consolas,monospace;font-size:12px;white-space:pre-wrap}
.hidden{display:none}
"""

SCRIPT = """
(function () {
  var box = document.getElementById('search');
  function filter() {
    var q = box.value.trim().toLowerCase();
    var shown = 0;
    document.querySelectorAll('details.model').forEach(function (m) {
      var hit = !q || m.dataset.search.indexOf(q) >= 0;
      var inner = false;
      m.querySelectorAll('.ob').forEach(function (o) {
        var oh = !q || hit || o.dataset.search.indexOf(q) >= 0;
        o.classList.toggle('hidden', !oh);
        if (q && o.dataset.search.indexOf(q) >= 0) { inner = true; }
      });
      var keep = hit || inner;
      m.classList.toggle('hidden', !keep);
      // open what the query found inside a model; close again what an earlier query opened
      m.querySelectorAll('details.branch').forEach(function (d) {
        var found = q && d.querySelector('.ob:not(.hidden)') && inner;
        if (found && !d.open) { d.open = true; d.dataset.searchOpened = '1'; }
        if (!found && d.dataset.searchOpened) { d.open = false; delete d.dataset.searchOpened; }
      });
      if (q && inner && !m.open) { m.open = true; m.dataset.searchOpened = '1'; }
      if (!(q && inner) && m.dataset.searchOpened) { m.open = false; delete m.dataset.searchOpened; }
      var row = document.getElementById('row-' + m.id);
      if (row) { row.classList.toggle('hidden', !keep); }
      if (keep) { shown += 1; }
    });
    document.getElementById('shown').textContent = shown;
  }
  box.addEventListener('input', filter);
})();
"""


def html_report(entries: list[GateEntry], selected: int | None = None, title: str = "certiloop gate") -> str:
    """The page for the gate's entries; `selected` as in the JUnit report (fewer entries: interrupted)."""
    passed = sum(e.passed for e in entries)
    partial = selected is not None and len(entries) < selected
    verdicts = ("proved", "refuted", "unknown", "not supported")
    counts = {v: sum(e.verdict == v for e in entries) for v in verdicts}
    cards = [("models", len(entries)), ("met their expectation", passed), ("failed", len(entries) - passed),
             *((v, n) for v, n in counts.items() if n)]
    summary = "".join(f'<div class="card"><b>{n}</b>{escape(what)}</div>' for what, n in cards)
    verdict_line = ("every model met its expected verdict" if passed == len(entries) and not partial
                    else f"{len(entries) - passed} model(s) failed")
    interrupted = (f'<p class="problem">interrupted: a partial report of the {len(entries)} of {selected} '
                   "models finished</p>" if partial else "")
    rows = "".join(_summary_row(i, e) for i, e in enumerate(entries))
    models = "".join(_model(i, e) for i, e in enumerate(entries))
    return f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8">
<meta name="viewport" content="width=device-width, initial-scale=1">
<title>{escape(title)}</title><style>{CSS}</style></head>
<body><header><h1>{escape(title)}</h1><div>{escape(verdict_line)}</div></header>
<main>{interrupted}<div class="summary">{summary}</div>
<input id="search" type="search" placeholder="filter models and obligations (name, path, verdict, backend)"
 aria-label="filter models and obligations">
<p><span id="shown">{len(entries)}</span> of {len(entries)} models shown</p>
<table class="models"><thead><tr><th>model</th><th>expected</th><th>verdict</th><th>obligations proved</th>
<th>falsifier</th><th>s</th><th>gate</th></tr></thead><tbody>{rows}</tbody></table>
{models}</main><script>{SCRIPT}</script></body></html>
"""


def _badge(verdict: str) -> str:
    known = {"proved", "refuted", "unknown", "rule failed", "not supported"}
    kind = verdict.replace(" ", "-") if verdict in known else "other"
    return f'<span class="v v-{kind}">{escape(verdict)}</span>'


def _gate(e: GateEntry) -> str:
    return '<span class="pass">PASS</span>' if e.passed else '<span class="fail">FAIL</span>'


def _proved(e: GateEntry) -> str:
    return f"{sum(o['verdict'] == 'proved' for o in e.obligations)}/{len(e.obligations)}"


def _summary_row(i: int, e: GateEntry) -> str:
    cached = " (cached)" if e.cached else ""
    return (f'<tr id="row-m{i}"><td><a href="#m{i}">{escape(e.model)}</a></td><td>{escape(e.expected)}</td>'
            f"<td>{_badge(e.verdict)}</td><td>{_proved(e)}</td>"
            f"<td>{escape(str(e.falsify.get('verdict', '—')))}</td><td>{e.seconds:.2f}{cached}</td>"
            f"<td>{_gate(e)}</td></tr>")


def _model(i: int, e: GateEntry) -> str:
    words = [e.model, e.expected, e.verdict, e.reason, "pass" if e.passed else "fail"]
    parts = [f"<p>expected <b>{escape(e.expected)}</b>, verdict {_badge(e.verdict)} — {_gate(e)}: "
             f"{escape(e.message)}</p>"]
    parts += [f'<div class="problem">{escape(p)}</div>' for p in e.problems]
    if e.verdict in ("unknown", "not supported") and e.reason and not any(e.reason in p for p in e.problems):
        parts.append(f'<div class="why">why {escape(e.verdict)}: {escape(e.reason)}</div>')
    parts.append(_checks(e))
    if e.obligations:
        parts.append(f"<h4>obligations ({_proved(e)} proved)</h4>{_tree(e)}")
    if e.counterexample:
        parts.append(_counterexample(e.counterexample))
    open_attr = "" if e.passed else " open"  # a reviewer lands on the failures
    search = escape(" ".join(w for w in words if w).lower(), quote=True)
    return (f'<details class="model" id="m{i}" data-search="{search}"{open_attr}><summary>{_gate(e)} '
            f"{escape(e.model)} {_badge(e.verdict)} <small>expected {escape(e.expected)}, {_proved(e)} "
            f"obligations proved, {e.seconds:.2f} s</small></summary>{''.join(parts)}</details>")


def _checks(e: GateEntry) -> str:
    items = []
    if e.checked is not None:
        items.append(f"proof checker: {e.checked}")
    if e.falsify:
        f = e.falsify
        what = f"falsifier: {f.get('verdict')} after {f.get('examples')} examples"
        if f.get("violated"):
            what += f"; violated {f['violated']}" + (f" ({f['check']})" if f.get("check") else "")
        if f.get("note"):
            what += f"; {f['note']}"
        items.append(what)
    if e.replay is not None:
        items.append("prover's run replays in the interpreter" if e.replay["violated"]
                     else f"prover's run does NOT replay: {e.replay['message']}")
    if e.nonblocking is not None:
        items.append(f"vacuity (the control step always has a run): {e.nonblocking['verdict']}")
    if e.kernel is not None:
        items.append("shipped kernel matches a fresh extraction" if not e.kernel else e.kernel)
    if e.cross_check is not None:
        items.append(f"cvc5: {e.cross_check.get('summary', '')}")
    return "<ul>" + "".join(f"<li>{escape(str(x))}</li>" for x in items) + "</ul>" if items else ""


def _tree(e: GateEntry) -> str:
    """Obligations grouped by their path (`loop step / climb / ODE solve / ...`), one collapsible
    level per path segment; a branch holding an obligation that is not proved starts open."""
    root: dict = {}
    for o in e.obligations:
        node = root
        for part in o["path"].split(" / ")[:-1]:
            node = node.setdefault(part, {})
        node.setdefault("", []).append(o)
    return _branch(root, e)


def _branch(node: dict, e: GateEntry) -> str:
    out = [_obligation(o, e) for o in node.get("", [])]
    for name, child in node.items():
        if name == "":
            continue
        verdicts = _verdicts(child)
        summary = f"{sum(v == 'proved' for v in verdicts)}/{len(verdicts)} proved"
        opened = " open" if any(v != "proved" for v in verdicts) else ""
        out.append(f'<details class="branch"{opened}><summary>{escape(name)} <small>{summary}</small>'
                   f"</summary>{_branch(child, e)}</details>")
    return "".join(out)


def _verdicts(node: dict) -> list[str]:
    found = [o["verdict"] for o in node.get("", [])]
    for name, child in node.items():
        if name:
            found += _verdicts(child)
    return found


def _obligation(o: dict, e: GateEntry) -> str:
    shown = label(o["verdict"], o.get("rule", ""))
    backend = o.get("backend") or "—"
    search = escape(" ".join((o["id"], o["path"], shown, backend, o.get("reason", ""))).lower(), quote=True)
    why = "; ".join(x for x in (o.get("reason", ""), hint(o["verdict"], o.get("rule", ""))) if x)
    extra = f'<div class="why">{escape(why)}</div>' if why and o["verdict"] != "proved" else ""
    if o.get("counterexample") and o["verdict"] != "proved":
        values = ", ".join(f"{k} = {v}" for k, v in o["counterexample"].items())
        extra += f'<div class="trace">fails at ({escape(o.get("check") or "")}): {escape(values)}</div>'
    return (f'<div class="ob" data-search="{search}">{escape(o["id"])} {_badge(shown)} '
            f'{escape(o["path"])} <small>[{escape(backend)}, {o.get("seconds", 0):.3f} s]</small>'
            f"{extra}</div>")


def _counterexample(cex: dict) -> str:
    steps = [("start", cex.get("initial", {}))] + [(s.get("what", ""), s.get("state", {}))
                                                  for s in cex.get("trace", [])]
    lines = [f"start: {_values(cex.get('initial', {}))}"]
    lines += [f"[{s.get('path', '')}] {s.get('what', '')}  →  {_values(s.get('state', {}))}"
              for s in cex.get("trace", [])]
    lines.append(f"violated: {cex.get('violated', '')} (checked with {cex.get('check', '')})")
    return (f"<h4>counterexample run</h4>{_plots(steps)}"
            f'<div class="trace">{escape(chr(10).join(lines))}</div>')


def _values(state: dict) -> str:
    return ", ".join(f"{k} = {v}" for k, v in state.items())


def _number(text) -> float | None:
    try:
        return float(Fraction(str(text)))
    except (ValueError, ZeroDivisionError):
        try:
            return float(text)
        except (TypeError, ValueError):
            return None  # an algebraic number written as a root, a Boolean: not plotted


def _plots(steps: list[tuple[str, dict]]) -> str:
    """One small chart per variable that changes along the run, value against step."""
    names = sorted({k for _, state in steps for k in state})
    charts = []
    for name in names:
        series = [_number(state.get(name)) if name in state else None for _, state in steps]
        known = [x for x in series if x is not None]
        if len(known) < 2 or len(set(known)) < 2:
            continue
        charts.append(_chart(name, series, [what for what, _ in steps]))
        if len(charts) == MAX_PLOTS:
            break
    return f'<div class="plots">{"".join(charts)}</div>' if charts else ""


def _chart(name: str, series: list[float | None], steps: list[str], width: int = 260,
           height: int = 120) -> str:
    pad = 28
    known = [x for x in series if x is not None]
    low, high = min(known), max(known)
    span = high - low
    last = max(len(series) - 1, 1)

    def at(i: int, y: float) -> tuple[float, float]:
        return (pad + (width - pad - 6) * i / last, height - 16 - (height - 28) * (y - low) / span)

    points = [(at(i, y), steps[i]) for i, y in enumerate(series) if y is not None]
    line = " ".join(f"{x:.1f},{y:.1f}" for (x, y), _ in points)
    dots = "".join(f'<circle cx="{x:.1f}" cy="{y:.1f}" r="3" fill="#1565c0"><title>{escape(what)}</title>'
                   "</circle>" for (x, y), what in points)
    return (f'<figure><svg xmlns="http://www.w3.org/2000/svg" width="{width}" height="{height}" '
            f'viewBox="0 0 {width} {height}" role="img" '
            f'aria-label="{escape(name, quote=True)} along the run">'
            f'<line x1="{pad}" y1="{height - 16}" x2="{width - 4}" y2="{height - 16}" stroke="#b8bfcc"/>'
            f'<line x1="{pad}" y1="8" x2="{pad}" y2="{height - 16}" stroke="#b8bfcc"/>'
            f'<text x="2" y="14" font-size="10">{_short(high)}</text>'
            f'<text x="2" y="{height - 16}" font-size="10">{_short(low)}</text>'
            f'<text x="{pad}" y="{height - 3}" font-size="10">step 0 … {len(series) - 1}</text>'
            f'<polyline fill="none" stroke="#1565c0" stroke-width="2" points="{line}"/>{dots}</svg>'
            f"<figcaption>{escape(name)}</figcaption></figure>")


def _short(x: float) -> str:
    return f"{x:.3g}"
