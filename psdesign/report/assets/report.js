// psdesign report helpers: K units, sortable tables, paged thumbnails, error trap.
window.PSD_ERRORS = [];
window.addEventListener('error', function (e) {
  var box = document.getElementById('psd-js-errors');
  if (box) { box.textContent += (e.message || 'error') + '\n'; }
});
function psdSetUnit(u) {
  var f = window.PSD_UNITS[u];
  document.querySelectorAll('td[data-m2]').forEach(function (td) {
    var v = parseFloat(td.getAttribute('data-m2'));
    td.textContent = isFinite(v) ? (v * f).toPrecision(4) : '';
  });
  document.querySelectorAll('.psd-kunit').forEach(function (s) {
    s.textContent = window.PSD_UNIT_LABELS[u];
  });
  (window.PSD_KFIGS || []).forEach(function (fig) {
    var el = document.getElementById(fig.id);
    if (!el || !window.Plotly) { return; }
    var scale = function (arr) {
      return arr ? arr.map(function (v) { return v === null ? null : v * f; }) : null;
    };
    var ys = fig.y.map(scale);
    var upd = {y: ys};
    if (fig.err) {
      upd['error_y.array'] = fig.err.map(scale);
    }
    Plotly.restyle(el, upd, fig.traces);
    var lay = {}; lay[fig.axis + '.title.text'] = fig.label + ' (' + window.PSD_UNIT_LABELS[u] + ')';
    Plotly.relayout(el, lay);
  });
}
function psdSort(th) {
  var table = th.closest('table'), idx = Array.prototype.indexOf.call(th.parentNode.children, th);
  var body = table.tBodies[0], rows = Array.prototype.slice.call(body.rows);
  var asc = th.getAttribute('data-order') !== 'asc';
  rows.sort(function (a, b) {
    var x = a.cells[idx].getAttribute('data-m2') || a.cells[idx].textContent;
    var y = b.cells[idx].getAttribute('data-m2') || b.cells[idx].textContent;
    var nx = parseFloat(x), ny = parseFloat(y);
    var c = (isFinite(nx) && isFinite(ny)) ? nx - ny : x.localeCompare(y);
    return asc ? c : -c;
  });
  rows.forEach(function (r) { body.appendChild(r); });
  table.querySelectorAll('th').forEach(function (h) { h.removeAttribute('data-order'); });
  th.setAttribute('data-order', asc ? 'asc' : 'desc');
}
function psdPage(gallery, page) {
  var g = document.getElementById(gallery), n = parseInt(g.getAttribute('data-per-page'));
  var items = g.querySelectorAll('figure');
  var pages = Math.max(1, Math.ceil(items.length / n));
  page = Math.min(Math.max(page, 0), pages - 1);
  items.forEach(function (f, i) {
    var on = Math.floor(i / n) === page;
    f.style.display = on ? '' : 'none';
    var img = f.querySelector('img[data-src]');
    if (on && img && !img.src) { img.src = img.getAttribute('data-src'); }
  });
  g.setAttribute('data-page', page);
  var lab = document.getElementById(gallery + '-label');
  if (lab) { lab.textContent = 'page ' + (page + 1) + ' of ' + pages; }
}
document.addEventListener('DOMContentLoaded', function () {
  document.querySelectorAll('.psd-gallery').forEach(function (g) { psdPage(g.id, 0); });
  document.querySelectorAll('table.sortable th').forEach(function (th) {
    th.addEventListener('click', function () { psdSort(th); });
  });
  // the figures exist once plotly.js is unpacked and has drawn them (plotly_loader.js); a
  // browser that cannot unpack it says so, and its tables still follow the unit selector
  (window.PSD_PLOTLY || Promise.resolve()).catch(function (e) {
    var box = document.getElementById('psd-js-errors');
    if (box) { box.textContent += (e && e.message || 'error') + '\n'; }
  }).then(function () {
    var sel = document.getElementById('psd-unit');
    if (sel) { sel.addEventListener('change', function () { psdSetUnit(sel.value); }); }
    var m = /unit=(\w+)/.exec(window.location.hash);  // report.html#unit=darcy
    if (sel && m && window.PSD_UNITS[m[1]]) { sel.value = m[1]; psdSetUnit(m[1]); }
    document.body.setAttribute('data-psd-ready', '1');
  });
});
