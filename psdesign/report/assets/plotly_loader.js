// psdesign report: plotly.js is inlined gzip-compressed (1.9 MB of base64 instead of the 4.8 MB
// script: 82 % of a 12-case report was the library). The browser unpacks it (no network), runs
// it, then the figures' scripts (type "text/psd-plot", in page order). window.PSD_PLOTLY is the
// promise report.js waits on before the unit selector touches a figure.
window.PSD_PLOTLY = (async function () {
  if (!window.DecompressionStream) {
    throw new Error('this browser cannot unpack the report\'s figures (DecompressionStream: ' +
                    'Chrome 80, Firefox 113, Safari 16.4 or later); the tables still hold every value');
  }
  var bin = atob(document.getElementById('psd-plotly-gz').textContent.trim());
  var bytes = new Uint8Array(bin.length);
  for (var i = 0; i < bin.length; i++) { bytes[i] = bin.charCodeAt(i); }
  var stream = new Blob([bytes]).stream().pipeThrough(new DecompressionStream('gzip'));
  var code = await new Response(stream).text();
  await new Promise(function (ok) {
    if (document.readyState === 'loading') {
      document.addEventListener('DOMContentLoaded', ok);
    } else { ok(); }
  });
  var run = function (text) {  // a script element runs synchronously, in the global scope
    var s = document.createElement('script');
    s.text = text;
    document.head.appendChild(s);
  };
  run(code);
  document.querySelectorAll('script[type="text/psd-plot"]').forEach(function (s) { run(s.text); });
})();
