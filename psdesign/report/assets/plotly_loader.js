// psdesign report: plotly.js is inlined gzip-compressed (1.9 MB of base64 instead of the 4.8 MB
// script: 82 % of a 12-case report was the library). The browser unpacks it (no network), runs
// it, then the figures' scripts (type "text/psd-plot", in page order). window.PSD_PLOTLY is the
// promise report.js waits on before the unit selector touches a figure.
// Unpacking: the browser's DecompressionStream (Chrome 80, Firefox 113, Safari 16.4), else the
// inflater inlined as text in #psd-inflate (fflate's gunzip, assets/fflate_gunzip.min.js, 7 KB),
// run only then: Safari 15-16.3 and Firefox ESR 102 lack DecompressionStream. Plain ES5 and
// promises (no async/await) so that an old browser reaches the message below, not a SyntaxError.
(function () {
  var CANNOT = 'this browser cannot unpack the report\'s interactive figures (no ' +
    'DecompressionStream, which Chrome 80, Firefox 113 and Safari 16.4 have, and the report\'s ' +
    'own inflater needs typed arrays and ES2015); the tables and pictures still hold every value';
  var run = function (text) {  // a script element runs synchronously, in the global scope
    var s = document.createElement('script');
    s.text = text;
    document.head.appendChild(s);
  };
  var packed = function () {  // the gzip bytes of plotly.js
    var bin = atob(document.getElementById('psd-plotly-gz').textContent.trim());
    var bytes = new Uint8Array(bin.length);
    for (var i = 0; i < bin.length; i++) { bytes[i] = bin.charCodeAt(i); }
    return bytes;
  };
  var native = function (bytes) {
    var stream = new Blob([bytes]).stream().pipeThrough(new DecompressionStream('gzip'));
    return new Response(stream).text();
  };
  var inflate = function (bytes) {
    if (!window.psdInflate) { run(document.getElementById('psd-inflate').textContent); }
    if (!window.psdInflate) { throw new Error(CANNOT); }  // it did not run here (ES2015 code)
    return Promise.resolve(window.psdInflate.strFromU8(window.psdInflate.gunzipSync(bytes)));
  };
  // both ways, for the browser test (tests/cli/test_report_browser.py): they unpack the same text
  window.PSD_GUNZIP = {packed: packed, native: native, inflate: inflate};
  var way = window.DecompressionStream ? 'native' : (typeof Uint8Array === 'function' &&
    window.atob && document.getElementById('psd-inflate')) ? 'inflate' : null;
  var parsed = new Promise(function (ok) {
    if (document.readyState === 'loading') {
      document.addEventListener('DOMContentLoaded', ok);
    } else { ok(); }
  });
  window.PSD_PLOTLY = (way ? Promise.resolve() : Promise.reject(new Error(CANNOT)))
    .then(function () { return window.PSD_GUNZIP[way](packed()); })
    .then(function (code) {
      return parsed.then(function () {
        run(code);
        document.body.setAttribute('data-psd-gunzip', way);
        var plots = document.querySelectorAll('script[type="text/psd-plot"]');
        for (var i = 0; i < plots.length; i++) { run(plots[i].text); }
      });
    });
})();
