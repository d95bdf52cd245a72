// slate dashboard: receives snapshots (WebSocket, or polling /api/snapshot as a fallback) and
// renders every section. Every field of a snapshot is optional and may have the wrong type:
// all reads go through the guards below, and each section renders on its own, so one bad
// section never blanks the others.
(() => {
  'use strict';

  // ---- guards -------------------------------------------------------------------------
  const isObj = (v) => v !== null && typeof v === 'object' && !Array.isArray(v);
  const arr = (v) => (Array.isArray(v) ? v : []);
  const obj = (v) => (isObj(v) ? v : {});
  const num = (v) => (typeof v === 'number' && Number.isFinite(v) ? v : null);
  const clamp01 = (v) => Math.min(1, Math.max(0, v));
  const json = (v) => {
    try { return JSON.stringify(v); } catch (e) { return '?'; }
  };
  const str = (v) => {
    if (v === null || v === undefined) return '';
    if (typeof v === 'string') return v;
    if (typeof v === 'object') return json(v);
    return String(v);
  };

  // ---- formatting ---------------------------------------------------------------------
  const fmt = (v, digits = 2) => {
    const n = num(v);
    if (n === null) return '–';
    if (Math.abs(n) >= 1e5) return n.toExponential(2);
    return String(Number(n.toFixed(digits)));
  };
  const fmtUnit = (v, unit) => {
    const n = num(v);
    if (n === null) return '–';
    const steps = ['', 'k', 'M', 'G', 'T'];
    let i = 0;
    let x = n;
    while (Math.abs(x) >= 1000 && i < steps.length - 1) { x /= 1000; i += 1; }
    const digits = i === 0 || Math.abs(x) >= 100 ? 0 : 1;
    return x.toFixed(digits) + '\u202f' + steps[i] + unit;
  };
  const fmtAge = (v) => {
    const n = num(v);
    if (n === null) return '–';
    if (n < 60) return n.toFixed(n < 10 ? 1 : 0) + 's';
    if (n < 3600) return Math.floor(n / 60) + 'm' + String(Math.floor(n % 60)).padStart(2, '0');
    return (n / 3600).toFixed(1) + 'h';
  };

  // ---- DOM helpers ----------------------------------------------------------------------
  const $ = (id) => document.getElementById(id);
  function el(tag, props, ...children) {
    const node = document.createElement(tag);
    for (const [key, value] of Object.entries(props || {})) {
      if (value === undefined || value === null || value === false) continue;
      if (key === 'class') node.className = value;
      else if (key === 'text') node.textContent = value;
      else if (key === 'testid') node.dataset.testid = value;
      else if (key === 'style') node.setAttribute('style', value);
      else if (key.startsWith('on')) node.addEventListener(key.slice(2), value);
      else if (key.startsWith('data-')) node.setAttribute(key, value);
      else node[key] = value;
    }
    for (const child of children.flat()) {
      if (child === null || child === undefined || child === false) continue;
      node.append(child instanceof Node ? child : String(child));
    }
    return node;
  }
  const empty = (text) => el('div', { class: 'empty', text });
  const fill = (node, ...children) => {
    if (node) node.replaceChildren(...children.flat().filter((c) => c !== null && c !== undefined && c !== false));
  };

  // ---- state ----------------------------------------------------------------------------
  const state = {
    snap: {},
    received: 0,
    lastAt: 0,
    lastTime: null,
    selected: null,
    classFilter: null,
    textFilter: '',
    trails: new Map(),
    rendered: new Map(),
  };
  const keyOf = (o) => str(o.board) + '\u0000' + str(o.name);

  /** Runs one section's renderer; a failure is reported and leaves the other sections alone. */
  function safely(name, fn) {
    try { fn(); } catch (e) { console.error('slate dashboard: cannot render ' + name, e); }
  }

  /** True when `value` differs from what `section` last rendered (or `force`). */
  function changed(section, value, force) {
    const text = json(value);
    if (!force && state.rendered.get(section) === text) return false;
    state.rendered.set(section, text);
    return true;
  }

  function render(snapshot) {
    const snap = obj(snapshot);
    state.snap = snap;
    state.received += 1;
    state.lastAt = Date.now();
    safely('status', () => renderStatus(snap));
    safely('summary', () => changed('summary', snap.summary) && renderSummary(obj(snap.summary)));
    safely('map', () => { updateTrails(snap); drawMap(); });
    safely('links', () => changed('links', snap.links) && renderLinks(arr(snap.links)));
    safely('model', () => renderModel(false));
    safely('plans', () => changed('plans', snap.plans) && renderPlans(arr(snap.plans)));
    safely('events', () => changed('events', snap.events) && renderEvents(arr(snap.events)));
    const count = $('snapshot-count');
    if (count) count.textContent = String(state.received);
  }

  // ---- status line ------------------------------------------------------------------------
  function renderStatus(snap) {
    const title = str(snap.title) || 'slate';
    $('title').textContent = title;
    document.title = title + ' · slate dashboard';
    const status = str(snap.status);
    const pill = $('status');
    pill.textContent = status || '–';
    pill.dataset.state = ['running', 'finished', 'failed'].includes(status) ? status : 'none';
    const time = num(snap.time);
    const node = $('time');
    node.textContent = time === null ? '–' : time.toFixed(2);
    node.dataset.value = time === null ? '' : String(time);
  }

  function renderSummary(summary) {
    const entries = Object.entries(summary);
    if (entries.length === 0) { fill($('summary'), empty('no summary')); return; }
    fill($('summary'), entries.map(([key, value]) => {
      const text = typeof value === 'number' ? fmt(value, 3) : str(value);
      return el('div', { title: key + ': ' + text }, el('dt', { text: key }), el('dd', { text }));
    }));
  }

  // ---- map ----------------------------------------------------------------------------------
  const PALETTE = ['#4cc2ff', '#ff7ab6', '#7ee787', '#ffa657', '#d2a8ff', '#f2cc60', '#79e2f2', '#ff9b8a'];
  const KIND_ORDER = { obstacle: 0, goal: 1, other: 2, target: 3, robot: 4 };
  const TRAIL_POINTS = 90;
  let view = null;
  let hovered = null;

  const hash = (s) => { let h = 2166136261; for (let i = 0; i < s.length; i += 1) { h = Math.imul(h ^ s.charCodeAt(i), 16777619); } return h >>> 0; };
  const robotColor = (id) => PALETTE[hash(id) % PALETTE.length];
  const kindOf = (it) => { const k = str(it.kind); return k in KIND_ORDER ? k : 'other'; };
  const idOf = (it, i) => str(it.id) || str(it.label) || '#' + i;

  /** The map's items that can be placed: objects with finite x and y. */
  function mapItems(snap) {
    return arr(obj(snap.map).items)
      .filter((it) => isObj(it) && num(it.x) !== null && num(it.y) !== null)
      .map((it, i) => ({ ...it, _id: idOf(it, i), _kind: kindOf(it) }));
  }

  function updateTrails(snap) {
    const time = num(snap.time);
    if (time !== null && state.lastTime !== null && time < state.lastTime) state.trails.clear();
    state.lastTime = time;
    const seen = new Set();
    for (const it of mapItems(snap)) {
      if (it._kind !== 'robot') continue;
      seen.add(it._id);
      const trail = state.trails.get(it._id) || [];
      const last = trail[trail.length - 1];
      if (!last || last.x !== it.x || last.y !== it.y) trail.push({ x: it.x, y: it.y });
      if (trail.length > TRAIL_POINTS) trail.splice(0, trail.length - TRAIL_POINTS);
      state.trails.set(it._id, trail);
    }
    for (const id of [...state.trails.keys()]) if (!seen.has(id)) state.trails.delete(id);
  }

  /** [xmin, ymin, xmax, ymax] from the snapshot, or around the items, or a default square. */
  function boundsOf(snap, items) {
    const b = arr(obj(snap.map).bounds).map(num);
    if (b.length === 4 && b.every((v) => v !== null) && b[2] > b[0] && b[3] > b[1]) return b;
    if (items.length === 0) return [0, 0, 100, 100];
    const xs = items.map((it) => it.x);
    const ys = items.map((it) => it.y);
    const [x0, x1, y0, y1] = [Math.min(...xs), Math.max(...xs), Math.min(...ys), Math.max(...ys)];
    const pad = Math.max(1, (x1 - x0) * 0.1, (y1 - y0) * 0.1);
    return [x0 - pad, y0 - pad, x1 + pad, y1 + pad];
  }

  function makeView(bounds, width, height) {
    const margin = 28;
    const [x0, y0, x1, y1] = bounds;
    const s = Math.max(1e-9, Math.min((width - 2 * margin) / (x1 - x0), (height - 2 * margin) / (y1 - y0)));
    const ox = (width - (x1 - x0) * s) / 2;
    const oy = (height - (y1 - y0) * s) / 2;
    return { bounds, s, width, height, X: (x) => ox + (x - x0) * s, Y: (y) => oy + (y1 - y) * s };
  }

  /** Sizes the canvas to its box (in device pixels); returns the context or null. */
  function prepareCanvas() {
    const canvas = $('map');
    const ctx = canvas && canvas.getContext ? canvas.getContext('2d') : null;
    if (!ctx) return null;
    const rect = canvas.getBoundingClientRect();
    const dpr = window.devicePixelRatio || 1;
    const w = Math.max(1, Math.round(rect.width));
    const h = Math.max(1, Math.round(rect.height));
    if (canvas.width !== Math.round(w * dpr) || canvas.height !== Math.round(h * dpr)) {
      canvas.width = Math.round(w * dpr);
      canvas.height = Math.round(h * dpr);
    }
    ctx.setTransform(dpr, 0, 0, dpr, 0, 0);
    ctx.clearRect(0, 0, w, h);
    return { ctx, w, h };
  }

  function drawMap() {
    const prepared = prepareCanvas();
    if (!prepared) return;
    const { ctx, w, h } = prepared;
    const items = mapItems(state.snap);
    view = makeView(boundsOf(state.snap, items), w, h);
    drawGrid(ctx, view);
    drawTrails(ctx, view);
    items.sort((a, b) => KIND_ORDER[a._kind] - KIND_ORDER[b._kind]);
    let robots = 0;
    for (const it of items) {
      ctx.save();
      drawItem(ctx, view, it);
      ctx.restore();
      if (it._kind === 'robot') robots += 1;
    }
    view.items = items;
    $('robot-count').textContent = String(robots);
    $('item-count').textContent = String(items.length);
    if (hovered) showTooltip(hovered.px, hovered.py);
  }

  function niceStep(span) {
    const raw = span / 8;
    const pow = Math.pow(10, Math.floor(Math.log10(raw)));
    for (const m of [1, 2, 5, 10]) if (m * pow >= raw) return m * pow;
    return 10 * pow;
  }

  function drawGrid(ctx, v) {
    const [x0, y0, x1, y1] = v.bounds;
    ctx.fillStyle = '#0f151d';
    ctx.fillRect(v.X(x0), v.Y(y1), (x1 - x0) * v.s, (y1 - y0) * v.s);
    const step = niceStep(Math.max(x1 - x0, y1 - y0));
    ctx.lineWidth = 1;
    ctx.font = '10px ' + getComputedStyle(document.body).getPropertyValue('--mono');
    ctx.fillStyle = '#5d6b7b';
    ctx.textAlign = 'center';
    ctx.textBaseline = 'top';
    for (let x = Math.ceil(x0 / step) * step; x <= x1 + 1e-9; x += step) {
      const px = Math.round(v.X(x)) + 0.5;
      gridLine(ctx, px, v.Y(y0), px, v.Y(y1), Math.abs(x) < 1e-9);
      ctx.fillText(fmt(x, 3), px, v.Y(y0) + 5);
    }
    ctx.textAlign = 'right';
    ctx.textBaseline = 'middle';
    for (let y = Math.ceil(y0 / step) * step; y <= y1 + 1e-9; y += step) {
      const py = Math.round(v.Y(y)) + 0.5;
      gridLine(ctx, v.X(x0), py, v.X(x1), py, Math.abs(y) < 1e-9);
      ctx.fillText(fmt(y, 3), v.X(x0) - 5, py);
    }
    ctx.strokeStyle = '#2c3a4b';
    ctx.strokeRect(Math.round(v.X(x0)) + 0.5, Math.round(v.Y(y1)) + 0.5, Math.round((x1 - x0) * v.s), Math.round((y1 - y0) * v.s));
  }

  function gridLine(ctx, ax, ay, bx, by, axis) {
    ctx.strokeStyle = axis ? '#2b3a4c' : '#18212c';
    ctx.beginPath();
    ctx.moveTo(ax, ay);
    ctx.lineTo(bx, by);
    ctx.stroke();
  }

  function drawTrails(ctx, v) {
    ctx.lineWidth = 1.5;
    ctx.lineJoin = 'round';
    for (const [id, trail] of state.trails) {
      if (trail.length < 2) continue;
      ctx.strokeStyle = robotColor(id);
      ctx.globalAlpha = 0.28;
      ctx.beginPath();
      trail.forEach((p, i) => (i === 0 ? ctx.moveTo(v.X(p.x), v.Y(p.y)) : ctx.lineTo(v.X(p.x), v.Y(p.y))));
      ctx.stroke();
    }
    ctx.globalAlpha = 1;
  }

  function itemColor(it) {
    if (it._kind === 'robot') return robotColor(it._id);
    if (it._kind === 'target') return str(it.found_by) ? '#3fcf8e' : '#f5b84a';
    if (it._kind === 'goal') return '#5de4c7';
    if (it._kind === 'obstacle') return '#8a96a6';
    return '#9aa7b6';
  }

  /** Confidence sets opacity (never invisible); stale data is faded further. */
  function itemAlpha(it) {
    const conf = num(it.confidence);
    const alpha = conf === null ? 1 : 0.3 + 0.7 * clamp01(conf);
    return it.stale === true ? alpha * 0.45 : alpha;
  }

  function drawItem(ctx, v, it) {
    const x = v.X(it.x);
    const y = v.Y(it.y);
    const color = itemColor(it);
    const stale = it.stale === true;
    ctx.globalAlpha = itemAlpha(it);
    drawAccuracy(ctx, v, it, x, y, color, stale);
    ctx.setLineDash(stale ? [3, 3] : []);
    MARKERS[it._kind](ctx, v, it, x, y, color);
    ctx.setLineDash([]);
    if (it.alive === false) drawCross(ctx, x, y);
    if (isSelected(it)) drawSelection(ctx, x, y);
    drawLabel(ctx, v, it, x, y);
  }

  function drawAccuracy(ctx, v, it, x, y, color, stale) {
    const acc = num(it.accuracy);
    if (acc === null || acc <= 0) return;
    const r = acc * v.s;
    if (r < 1.5 || r > 4 * Math.max(v.width, v.height)) return;
    ctx.beginPath();
    ctx.arc(x, y, r, 0, 2 * Math.PI);
    ctx.fillStyle = color + '1f';
    ctx.fill();
    ctx.setLineDash(stale ? [4, 4] : []);
    ctx.strokeStyle = color + '99';
    ctx.lineWidth = 1;
    ctx.stroke();
    ctx.setLineDash([]);
  }

  const MARKERS = {
    robot(ctx, v, it, x, y, color) {
      const heading = num(it.heading);
      ctx.fillStyle = color;
      ctx.strokeStyle = '#0d1117';
      ctx.lineWidth = 1.5;
      if (heading === null) {
        ctx.beginPath();
        ctx.arc(x, y, 7, 0, 2 * Math.PI);
        ctx.fill();
        ctx.stroke();
        return;
      }
      ctx.save();
      ctx.translate(x, y);
      ctx.rotate(-heading); // map y points up, canvas y down
      ctx.beginPath();
      ctx.moveTo(12, 0);
      ctx.lineTo(-7, 7.5);
      ctx.lineTo(-3, 0);
      ctx.lineTo(-7, -7.5);
      ctx.closePath();
      ctx.fill();
      ctx.stroke();
      ctx.restore();
    },
    obstacle(ctx, v, it, x, y) {
      const radius = num(it.radius);
      const r = radius !== null && radius > 0 ? Math.max(3, radius * v.s) : 6;
      ctx.beginPath();
      ctx.arc(x, y, r, 0, 2 * Math.PI);
      ctx.fillStyle = '#3a4452';
      ctx.fill();
      ctx.strokeStyle = '#8a96a6';
      ctx.lineWidth = 1.2;
      ctx.stroke();
    },
    target(ctx, v, it, x, y, color) {
      ctx.beginPath();
      ctx.moveTo(x, y - 8);
      ctx.lineTo(x + 8, y);
      ctx.lineTo(x, y + 8);
      ctx.lineTo(x - 8, y);
      ctx.closePath();
      ctx.fillStyle = color;
      ctx.fill();
      ctx.strokeStyle = '#0d1117';
      ctx.lineWidth = 1.5;
      ctx.stroke();
    },
    goal(ctx, v, it, x, y, color) {
      ctx.strokeStyle = color;
      ctx.lineWidth = 2;
      for (const r of [9, 4]) {
        ctx.beginPath();
        ctx.arc(x, y, r, 0, 2 * Math.PI);
        ctx.stroke();
      }
    },
    other(ctx, v, it, x, y, color) {
      ctx.fillStyle = color;
      ctx.fillRect(x - 4, y - 4, 8, 8);
      ctx.strokeStyle = '#0d1117';
      ctx.strokeRect(x - 4, y - 4, 8, 8);
    },
  };

  function drawCross(ctx, x, y) {
    ctx.globalAlpha = 1;
    ctx.strokeStyle = '#ff6b6b';
    ctx.lineWidth = 2.5;
    ctx.lineCap = 'round';
    ctx.beginPath();
    ctx.moveTo(x - 10, y - 10);
    ctx.lineTo(x + 10, y + 10);
    ctx.moveTo(x + 10, y - 10);
    ctx.lineTo(x - 10, y + 10);
    ctx.stroke();
  }

  function drawSelection(ctx, x, y) {
    ctx.globalAlpha = 1;
    ctx.strokeStyle = '#ffffff';
    ctx.lineWidth = 1.5;
    ctx.setLineDash([2, 3]);
    ctx.beginPath();
    ctx.arc(x, y, 16, 0, 2 * Math.PI);
    ctx.stroke();
    ctx.setLineDash([]);
  }

  function drawLabel(ctx, v, it, x, y) {
    let label = str(it.label) || it._id;
    if (it.alive === false) label += ' (lost)';
    else if (it.stale === true) label += ' (stale)';
    if (it._kind === 'obstacle' && !str(it.label)) return;
    ctx.globalAlpha = it.stale === true || it.alive === false ? 0.75 : 1;
    ctx.font = (it._kind === 'robot' ? '600 12px ' : '11px ') + getComputedStyle(document.body).fontFamily;
    ctx.textAlign = 'left';
    ctx.textBaseline = 'middle';
    // Right of the marker, or left of it where the right would leave the canvas.
    const width = ctx.measureText(label).width;
    const lx = x + 12 + width > v.width - 2 ? x - 12 - width : x + 12;
    const ly = Math.max(8, y - 11);
    ctx.lineWidth = 3;
    ctx.strokeStyle = '#0d1117';
    ctx.strokeText(label, lx, ly);
    ctx.fillStyle = it.alive === false ? '#ff9b9b' : '#e6edf3';
    ctx.fillText(label, lx, ly);
  }

  function isSelected(it) {
    const selected = selectedObject();
    return selected !== null && str(selected.name) === it._id;
  }

  // Hover: the nearest item within reach shows its fields; a click selects a matching object.
  function nearestItem(px, py) {
    if (!view || !view.items) return null;
    let best = null;
    let bestD = 14 * 14;
    for (const it of view.items) {
      const d = (view.X(it.x) - px) ** 2 + (view.Y(it.y) - py) ** 2;
      if (d <= bestD) { best = it; bestD = d; }
    }
    return best;
  }

  function showTooltip(px, py) {
    const tip = $('tooltip');
    const it = nearestItem(px, py);
    if (!it) { tip.hidden = true; return; }
    const line = (key, value) => (value === '' || value === '–' ? null : el('div', {}, el('span', { class: 'muted', text: key + ' ' }), value));
    const heading = num(it.heading);
    fill(tip,
      el('div', {}, el('b', { text: str(it.label) || it._id }), el('span', { class: 'muted', text: ' ' + it._kind })),
      line('position', '(' + fmt(it.x) + ', ' + fmt(it.y) + ')'),
      line('heading', heading === null ? '' : fmt((heading * 180) / Math.PI, 0) + '°'),
      line('accuracy', num(it.accuracy) === null ? '' : '± ' + fmt(it.accuracy)),
      line('confidence', fmt(it.confidence)),
      line('age', num(it.age) === null ? '' : fmtAge(it.age)),
      line('state', [it.alive === false ? 'lost' : '', it.stale === true ? 'stale' : ''].filter(Boolean).join(', ')),
      line('owner', str(it.owner)),
      line('found by', str(it.found_by)),
      line('board', str(it.board)));
    tip.hidden = false;
    const wrap = $('map-wrap').getBoundingClientRect();
    const left = Math.min(px + 14, wrap.width - tip.offsetWidth - 4);
    const top = Math.min(py + 14, wrap.height - tip.offsetHeight - 4);
    tip.style.left = Math.max(4, left) + 'px';
    tip.style.top = Math.max(4, top) + 'px';
  }

  function bindMap() {
    const canvas = $('map');
    if (!canvas) return;
    const at = (e) => { const r = canvas.getBoundingClientRect(); return [e.clientX - r.left, e.clientY - r.top]; };
    canvas.addEventListener('mousemove', (e) => {
      const [px, py] = at(e);
      hovered = { px, py };
      safely('tooltip', () => showTooltip(px, py));
    });
    canvas.addEventListener('mouseleave', () => { hovered = null; $('tooltip').hidden = true; });
    canvas.addEventListener('click', (e) => safely('map click', () => {
      const it = nearestItem(...at(e));
      const match = it && modelObjects().find((o) => str(o.name) === it._id);
      if (match) select(keyOf(match));
    }));
    const redraw = () => safely('map', drawMap);
    if (typeof ResizeObserver === 'function') new ResizeObserver(redraw).observe($('map-wrap'));
    else window.addEventListener('resize', redraw);
  }

  // ---- links ---------------------------------------------------------------------------------
  function renderLinks(links) {
    const rows = links.filter(isObj);
    if (rows.length === 0) { fill($('links'), empty('no links')); return; }
    fill($('links'), rows.map(renderLink));
  }

  function renderLink(link) {
    const rate = num(link.bytes_per_s);
    const budget = num(link.budget_bps);
    const bounded = budget !== null && budget > 0;
    const ratio = bounded && rate !== null ? rate / budget : null;
    const level = ratio === null ? 'unbounded' : ratio >= 1 ? 'over' : ratio >= 0.75 ? 'mid' : '';
    const width = ratio === null ? (rate === null ? 0 : 100) : Math.min(100, ratio * 100);
    const rateText = fmtUnit(rate, 'B/s') + (bounded ? ' / ' + fmtUnit(budget, 'B/s') : '');
    return el('div', { class: 'link', testid: 'link-row' },
      el('div', { class: 'link-top' },
        el('span', { class: 'link-name', text: str(link.name) || 'link' }),
        str(link.kind) ? el('span', { class: 'kind', text: str(link.kind) }) : null,
        el('span', { class: 'link-rate' + (level === 'over' ? ' over' : ''), text: rateText })),
      el('div', { class: 'bar', title: ratio === null ? 'no budget' : Math.round(ratio * 100) + '% of budget' },
        el('span', { class: level, style: 'width:' + width.toFixed(1) + '%' })),
      el('div', { class: 'link-sub' },
        el('span', { text: ratio === null ? 'no budget' : Math.round(ratio * 100) + '% of budget' }),
        el('span', { text: 'total ' + fmtUnit(link.total_bytes, 'B') })));
  }

  // ---- classes, objects, inspector ----------------------------------------------------------------
  const modelObjects = () => arr(state.snap.objects).filter(isObj);
  const modelClasses = () => arr(state.snap.classes).filter((c) => isObj(c) && str(c.name));

  function renderModel(force) {
    const classes = modelClasses();
    const objects = modelObjects();
    const filters = { c: state.classFilter, t: state.textFilter, s: state.selected };
    if (changed('classes', [classes, objects.map((o) => str(o.class)), state.classFilter], force)) renderClasses(classes, objects);
    if (changed('objects', [objects.map((o) => [o.board, o.name, o.class, o.context, o.owner]), filters], force)) renderObjects(objects, classes);
    if (changed('inspector', [selectedObject(), state.selected], force)) renderInspector(selectedObject());
  }

  /** Parent name → child classes; classes whose parent is unknown (or form a cycle) are roots. */
  function classForest(classes) {
    const byName = new Map();
    for (const c of classes) if (!byName.has(str(c.name))) byName.set(str(c.name), c);
    const children = new Map();
    const roots = [];
    for (const c of byName.values()) {
      const parent = str(c.parent);
      if (parent && parent !== str(c.name) && byName.has(parent)) {
        if (!children.has(parent)) children.set(parent, []);
        children.get(parent).push(c);
      } else roots.push(c);
    }
    const reached = new Set();
    const walk = (c) => { if (reached.has(str(c.name))) return; reached.add(str(c.name)); (children.get(str(c.name)) || []).forEach(walk); };
    roots.forEach(walk);
    for (const c of byName.values()) if (!reached.has(str(c.name))) { roots.push(c); walk(c); }
    return { roots, children };
  }

  /** `name` and every class below it. */
  function classAndDescendants(name, classes) {
    const { children } = classForest(classes);
    const out = new Set();
    const walk = (n) => { if (out.has(n)) return; out.add(n); (children.get(n) || []).forEach((c) => walk(str(c.name))); };
    walk(name);
    return out;
  }

  function renderClasses(classes, objects) {
    if (classes.length === 0) { fill($('classes'), empty('no classes')); return; }
    const counts = new Map();
    for (const o of objects) counts.set(str(o.class), (counts.get(str(o.class)) || 0) + 1);
    const { roots, children } = classForest(classes);
    const seen = new Set();
    const branch = (list) => el('ul', {}, list.map((c) => {
      const name = str(c.name);
      if (seen.has(name)) return null;
      seen.add(name);
      const attrs = arr(c.attrs).map(str).filter(Boolean);
      const count = counts.get(name) || 0;
      const row = el('div', {
        class: 'class-row' + (state.classFilter === name ? ' selected' : ''),
        title: attrs.length ? name + ': ' + attrs.join(', ') : name,
        testid: 'class-row',
        onclick: () => setClassFilter(state.classFilter === name ? null : name),
      },
      el('span', { class: 'class-name', text: name }),
      count ? el('span', { class: 'class-count', text: '×' + count }) : null,
      attrs.length ? el('span', { class: 'class-attrs', text: attrs.join(', ') }) : null);
      const kids = children.get(name) || [];
      return el('li', {}, row, kids.length ? branch(kids) : null);
    }));
    fill($('classes'), branch(roots));
  }

  function objectMatches(o, classes, text) {
    if (state.classFilter && !classes.has(str(o.class))) return false;
    if (!text) return true;
    return [o.name, o.class, o.board, o.owner, o.context].some((v) => str(v).toLowerCase().includes(text));
  }

  function renderObjects(objects, classes) {
    const allowed = state.classFilter ? classAndDescendants(state.classFilter, classes) : null;
    const text = state.textFilter.trim().toLowerCase();
    const shown = objects.filter((o) => objectMatches(o, allowed || new Set(), text));
    if (!state.selected || !objects.some((o) => keyOf(o) === state.selected)) {
      state.selected = shown.length ? keyOf(shown[0]) : null;
    }
    $('object-note').textContent = objects.length ? shown.length + ' of ' + objects.length : '';
    const chip = $('class-chip');
    chip.hidden = !state.classFilter;
    chip.textContent = state.classFilter ? 'class: ' + state.classFilter + '  ✕' : '';
    if (shown.length === 0) { fill($('objects'), empty(objects.length ? 'no object matches' : 'no objects')); return; }
    fill($('objects'), shown.map((o) => {
      const key = keyOf(o);
      const ctx = str(o.context).toLowerCase();
      return el('div', {
        class: 'object-row' + (key === state.selected ? ' selected' : ''),
        testid: 'object-row',
        onclick: () => select(key),
      },
      el('span', { class: 'object-name', text: str(o.name) || '(unnamed)' }),
      el('span', { class: 'object-class', text: str(o.class) }),
      el('span', { class: 'object-board', text: str(o.board) }),
      el('span', { class: 'ctx', 'data-ctx': ctx, text: ctx }));
    }));
  }

  function selectedObject() {
    return modelObjects().find((o) => keyOf(o) === state.selected) || null;
  }

  function select(key) {
    state.selected = key;
    safely('model', () => renderModel(true));
    safely('map', drawMap);
  }

  function setClassFilter(name) {
    state.classFilter = name;
    state.selected = null;
    safely('model', () => renderModel(true));
    safely('map', drawMap);
  }

  function renderInspector(o) {
    if (!o) { $('inspector-note').textContent = ''; fill($('inspector'), empty('select an object')); return; }
    const attrs = arr(o.attrs).filter(isObj);
    $('inspector-note').textContent = attrs.length + ' attribute' + (attrs.length === 1 ? '' : 's');
    const field = (key, value) => el('div', {}, el('dt', { text: key }), el('dd', { text: str(value) || '–', title: str(value) }));
    const head = el('div', { class: 'inspect-head' },
      el('div', { class: 'big', text: str(o.name) || '(unnamed)' }),
      el('dl', {}, field('class', o.class), field('context', o.context), field('board', o.board), field('owner', o.owner)));
    const table = attrs.length === 0 ? empty('no attributes set') : el('table', { testid: 'inspector-table' },
      el('thead', {}, el('tr', {}, el('th', { text: 'attribute' }), el('th', { text: 'value ± acc' }),
        el('th', { class: 'right', text: 'conf' }), el('th', { class: 'right', text: 'age' }))),
      el('tbody', {}, attrs.map(attrRow)));
    fill($('inspector'), head, table);
  }

  function attrRow(a) {
    const conf = num(a.confidence);
    const age = num(a.age);
    const acc = num(a.accuracy);
    return el('tr', { testid: 'attr-row' },
      el('td', {}, el('div', { class: 'attr-name', text: str(a.name) }),
        str(a.source) ? el('div', { class: 'source', text: str(a.source), title: str(a.source) }) : null),
      el('td', { class: 'value' }, str(a.value) || '–', acc === null ? null : el('span', { class: 'acc', text: ' ± ' + fmt(acc, 3) })),
      el('td', { class: 'num' }, conf === null ? '–' : el('span', { class: 'conf' },
        el('i', {}, el('b', { style: 'width:' + (clamp01(conf) * 100).toFixed(0) + '%' })), fmt(conf))),
      el('td', { class: 'num' + (age !== null && age > 5 ? ' old' : ''), text: fmtAge(age) }));
  }

  // ---- plans ----------------------------------------------------------------------------------------
  const PLAN_STATE = [
    [/fail|reject|lost|error/, 'bad'],
    [/cancel|suspend/, 'warn'],
    [/terminat|done|complete|finish/, 'done'],
    [/active|run|trigger|initiat/, 'ok'],
  ];
  const planLevel = (s) => (PLAN_STATE.find(([re]) => re.test(s)) || [null, 'none'])[1];

  function renderPlans(plans) {
    const rows = plans.filter(isObj);
    $('plan-note').textContent = rows.length ? rows.length + ' plan' + (rows.length === 1 ? '' : 's') : '';
    if (rows.length === 0) { fill($('plans'), empty('no plans')); return; }
    fill($('plans'), el('table', { class: 'fixed' },
      el('colgroup', {}, el('col', {}), el('col', { class: 'col-state' }), el('col', { class: 'col-fired' })),
      el('thead', {}, el('tr', {}, el('th', { text: 'plan · acks' }), el('th', { text: 'state' }), el('th', { class: 'right', text: 'fired' }))),
      el('tbody', {}, rows.map(planRow))));
  }

  function planRow(p) {
    const stateText = str(p.state).toLowerCase();
    const acks = arr(p.acks).map(str).filter(Boolean);
    const origin = str(p.origin);
    const where = str(p.board) + (origin ? '  ← ' + origin : '');
    return el('tr', { testid: 'plan-row' },
      el('td', {},
        el('div', { class: 'plan-name', text: str(p.name) || '(unnamed)' }),
        el('div', { class: 'plan-board', text: where, title: where }),
        acks.length ? el('div', { class: 'acks', title: origin ? 'acknowledgements to ' + origin : '' }, acks.map((a, i) => {
          const tone = /fail|reject|lost|error|cancel/.test(a.toLowerCase()) ? ' bad' : i === acks.length - 1 ? ' last' : '';
          return el('span', { class: 'ack' + tone, text: a });
        })) : null,
        str(p.last_error) ? el('div', { class: 'plan-error', text: '⚠ ' + str(p.last_error) }) : null),
      el('td', {}, el('span', { class: 'pill', 'data-state': planLevel(stateText), text: stateText || '–' })),
      el('td', { class: 'num', text: num(p.fired) === null ? '–' : String(p.fired) }));
  }

  // ---- events -----------------------------------------------------------------------------------------
  const MAX_EVENTS = 300;

  function renderEvents(events) {
    const rows = events.filter(isObj).map((e, i) => ({ e, i, t: num(e.t) }));
    rows.sort((a, b) => (b.t === null ? -Infinity : b.t) - (a.t === null ? -Infinity : a.t) || b.i - a.i);
    if (rows.length === 0) { fill($('events'), el('li', { class: 'empty', text: 'no events' })); return; }
    fill($('events'), rows.slice(0, MAX_EVENTS).map(({ e, t }) => {
      const level = ['info', 'warn', 'error'].includes(str(e.level)) ? str(e.level) : 'info';
      return el('li', { class: 'event', 'data-level': level, testid: 'event' },
        el('span', { class: 't', text: t === null ? '' : t.toFixed(1) + 's' }),
        el('span', { class: 'lvl', text: level }),
        el('span', { class: 'text', text: str(e.text) }));
    }));
  }

  // ---- transport: WebSocket, falling back to polling -----------------------------------------------
  const POLL_EVERY_MS = 500;
  const RETRY_WS_MS = 5000;
  const STALE_AFTER_MS = 3000;
  const forcePoll = new URLSearchParams(location.search).get('transport') === 'poll';
  let socket = null;
  let pollTimer = null;
  let polling = false;

  function setConn(kind, text) {
    const conn = $('conn');
    conn.dataset.state = kind;
    conn.textContent = text || kind;
  }

  function accept(text) {
    let snapshot;
    try { snapshot = JSON.parse(text); } catch (e) { setConn('error', 'bad snapshot'); return; }
    render(snapshot);
  }

  // The page's own `?token=...`, passed on to the snapshot and WebSocket routes (a
  // dashboard on an address other than loopback requires it).
  const tokenQuery = (() => {
    const token = new URLSearchParams(location.search).get('token');
    return token ? '?token=' + encodeURIComponent(token) : '';
  })();

  function connect() {
    if (forcePoll || typeof WebSocket !== 'function' || !location.host) { startPolling(); return; }
    try {
      socket = new WebSocket((location.protocol === 'https:' ? 'wss:' : 'ws:') + '//' + location.host + '/ws' + tokenQuery);
    } catch (e) { socket = null; startPolling(); setTimeout(connect, RETRY_WS_MS); return; }
    socket.onopen = () => { stopPolling(); setConn('live'); };
    socket.onmessage = (ev) => { if (typeof ev.data === 'string') accept(ev.data); };
    socket.onclose = () => { socket = null; startPolling(); setTimeout(connect, RETRY_WS_MS); };
  }

  function startPolling() {
    if (pollTimer !== null) return;
    setConn('polling');
    poll();
    pollTimer = setInterval(poll, POLL_EVERY_MS);
  }

  function stopPolling() {
    if (pollTimer !== null) clearInterval(pollTimer);
    pollTimer = null;
  }

  async function poll() {
    if (polling) return;
    polling = true;
    try {
      const response = await fetch('/api/snapshot' + tokenQuery, { cache: 'no-store' });
      if (response.ok) {
        accept(await response.text());
        if (!socket) setConn('polling');
      } else setConn('error', 'server error ' + response.status);
    } catch (e) {
      setConn('offline');
    } finally {
      polling = false;
    }
  }

  function watchdog() {
    const conn = $('conn');
    if (state.lastAt && Date.now() - state.lastAt > STALE_AFTER_MS && conn.dataset.state !== 'offline') {
      setConn('stale', 'no data for ' + Math.round((Date.now() - state.lastAt) / 1000) + 's');
    } else if (conn.dataset.state === 'stale' && Date.now() - state.lastAt <= STALE_AFTER_MS) {
      setConn(socket ? 'live' : 'polling');
    }
  }

  function bindControls() {
    const input = $('object-filter');
    input.addEventListener('input', () => { state.textFilter = input.value; safely('model', () => renderModel(true)); });
    $('class-chip').addEventListener('click', () => setClassFilter(null));
  }

  function start() {
    bindControls();
    bindMap();
    render({});
    state.received = 0;
    $('snapshot-count').textContent = '0';
    state.lastAt = 0;
    connect();
    setInterval(() => safely('watchdog', watchdog), 1000);
  }

  // Test hook: render a snapshot directly, inspect the state.
  window.slateDashboard = { render: (s) => render(s), state };
  start();
})();
