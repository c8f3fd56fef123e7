// Plotly figures of the airframe and flight pages, from JSON the page carries
// (<script type="application/json">). plotly.min.js is served by the app from the plotly package.
// No inline script anywhere: the pages' Content-Security-Policy allows scripts from the app only.
var MOTOR_COLOURS = ["#d62728", "#1f77b4", "#2ca02c", "#9467bd", "#ff7f0e", "#8c564b", "#e377c2", "#17becf"];
// background per window label: healthy, any motor damaged (1..n, any rotor count), uncertain
var SHADE_HEALTHY = "rgba(46,125,50,0.10)", SHADE_DAMAGED = "rgba(198,40,40,0.13)", SHADE_UNCERTAIN = "rgba(239,108,0,0.15)";

function readJSON(id) { var el = document.getElementById(id); return el ? JSON.parse(el.textContent) : null; }

function fdlogTrends() {
  var d = readJSON("trend-data"); if (!d || !window.Plotly) return;
  var root = document.getElementById("trends");
  var x = d.flights.map(function (f) { return f.n; });
  var names = d.flights.map(function (f) { return "#" + f.n + " " + f.name + " (" + f.status + ")"; });
  d.figures.forEach(function (fig) {
    var div = document.createElement("div"); div.className = "plot trend"; div.id = "trend-" + fig.field;
    root.appendChild(div);
    var traces = fig.lines.map(function (ln) {
      return {x: x, y: ln.y, text: names, mode: "lines+markers", name: "motor " + ln.motor,
              line: {color: MOTOR_COLOURS[(ln.motor - 1) % MOTOR_COLOURS.length]}, hovertemplate: "%{text}<br>" + fig.field + " %{y:.4f}<extra>motor " + ln.motor + "</extra>"};
    });
    Plotly.newPlot(div, traces, {title: {text: fig.title, font: {size: 14}}, height: 260, margin: {l: 60, r: 20, t: 36, b: 40},
      xaxis: {title: {text: "flight (time order)"}, dtick: 1}, legend: {orientation: "h"}}, {responsive: true, displaylogo: false});
  });
}

function fdlogFlight() {
  var d = readJSON("plot-data"); if (!d || !window.Plotly) return;
  var traces = [], p = d.plot || {rates: [], motors: []};
  (p.rates || []).forEach(function (ln, i) {
    traces.push({x: ln.t, y: ln.y, name: ln.name, yaxis: "y", mode: "lines", line: {width: 1}, legendgroup: "rates"});
  });
  (p.motors || []).forEach(function (ln, i) {
    traces.push({x: ln.t, y: ln.y, name: ln.name, yaxis: "y2", mode: "lines", line: {width: 1, color: MOTOR_COLOURS[i % MOTOR_COLOURS.length]}, legendgroup: "motors"});
  });
  var w = d.windows || [];
  if (w.length) {
    var cx = w.map(function (x) { return (x.t0 + x.t1) / 2; });
    var nClasses = w[0].p.length;  // healthy + one class per rotor
    for (var k = 0; k < nClasses; k++) {
      (function (k) {
        traces.push({x: cx, y: w.map(function (x) { return x.p[k]; }), name: "P(" + (k ? (d.rotor_word || "rotor") + " " + k : "healthy") + ")",
                     yaxis: "y3", mode: "lines", legendgroup: "classes",
                     line: {width: 1.5, color: k ? MOTOR_COLOURS[(k - 1) % MOTOR_COLOURS.length] : "#222222"}});
      })(k);
    }
  }
  // Windows overlap (stride < length): each shades from its start to the next window's start, so
  // translucent rectangles never stack into mixed colours.
  var sorted = w.slice().sort(function (a, b) { return a.t0 - b.t0; });
  var shapes = sorted.map(function (x, i) {
    var c = x.label === 0 ? SHADE_HEALTHY : x.label === -1 ? SHADE_UNCERTAIN : x.label > 0 ? SHADE_DAMAGED : null;
    if (!c) return null;
    var end = i + 1 < sorted.length ? Math.min(x.t1, sorted[i + 1].t0) : x.t1;
    return {type: "rect", xref: "x", yref: "paper", x0: x.t0, x1: end, y0: 0, y1: 1, fillcolor: c, line: {width: 0}, layer: "below"};
  }).filter(function (s) { return s; });
  var layout = {height: 720, margin: {l: 70, r: 20, t: 20, b: 50}, shapes: shapes, hovermode: "x",
    xaxis: {title: {text: "time on the log's clock (s)"}, anchor: "y3"},
    yaxis: {domain: [0.70, 1.0], title: {text: "rates (deg/s)"}},
    yaxis2: {domain: [0.37, 0.66], title: {text: "motor command"}, range: [0, 1.02]},
    yaxis3: {domain: [0.0, 0.33], title: {text: "class probability"}, range: [0, 1.02]},
    legend: {orientation: "h", y: -0.09}};
  Plotly.newPlot("flightplot", traces, layout, {responsive: true, displaylogo: false});
}

// Vibration level per IMU over time with the healthy reference (dashed), and the airborne gyro
// spectrum with the rotor rates marked (dashed verticals), from plot.vibration.
function fdlogVibration() {
  var d = readJSON("plot-data"); var v = d && d.plot && d.plot.vibration;
  if (!v || !window.Plotly) return;
  if (document.getElementById("vibplot") && v.series.length) {
    var traces = v.series.map(function (ln, i) {
      return {x: ln.t, y: ln.y, name: ln.name, mode: "lines", line: {width: 1, color: MOTOR_COLOURS[(i + 1) % MOTOR_COLOURS.length]}};
    });
    var shapes = [];
    if (v.reference !== null && v.reference !== undefined) {
      shapes.push({type: "line", xref: "paper", x0: 0, x1: 1, yref: "y", y0: v.reference, y1: v.reference, line: {dash: "dash", color: "#2e7d32", width: 2}});
      traces.push({x: [null], y: [null], name: v.reference_label, mode: "lines", line: {dash: "dash", color: "#2e7d32"}});
    }
    Plotly.newPlot("vibplot", traces, {height: 280, margin: {l: 70, r: 20, t: 20, b: 50}, shapes: shapes,
      xaxis: {title: {text: "time on the log's clock (s)"}}, yaxis: {title: {text: "vibration (" + v.unit + ")"}, rangemode: "tozero"},
      legend: {orientation: "h", y: -0.25}}, {responsive: true, displaylogo: false});
  }
  var sp = v.spectrum;
  if (document.getElementById("specplot") && sp) {
    var marks = sp.marks.map(function (m) {
      return {type: "line", xref: "x", x0: m.hz, x1: m.hz, yref: "paper", y0: 0, y1: 1, line: {dash: "dash", color: "#c62828", width: 1.5}};
    });
    var tr = [{x: sp.f, y: sp.db, name: "gyro", mode: "lines", line: {width: 1, color: "#1f77b4"}}];
    sp.marks.forEach(function (m) { tr.push({x: [m.hz], y: [Math.max.apply(null, sp.db)], name: m.label, mode: "markers", marker: {color: "#c62828", symbol: "triangle-down"}}); });
    Plotly.newPlot("specplot", tr, {height: 280, margin: {l: 70, r: 20, t: 20, b: 50}, shapes: marks,
      xaxis: {title: {text: "frequency (Hz)"}}, yaxis: {title: {text: "power (dB above band median)"}},
      legend: {orientation: "h", y: -0.25}}, {responsive: true, displaylogo: false});
  }
}

document.addEventListener("DOMContentLoaded", function () {
  if (document.getElementById("trend-data")) fdlogTrends();
  if (document.getElementById("plot-data")) { fdlogFlight(); fdlogVibration(); }
  var v = document.getElementById("verdict");  // a flight still queued or running: look again soon
  if (v && (v.dataset.state === "queued" || v.dataset.state === "running")) setTimeout(function () { location.reload(); }, 1500);
});
