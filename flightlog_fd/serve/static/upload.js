// Browser upload: one request per file, with progress (XMLHttpRequest upload events), signed-in
// session cookie + CSRF header; then poll /api/logs/ID until the verdict is there.
(function () {
  var btn = document.getElementById("upload-btn");
  if (!btn) return;
  function row(text) {
    var li = document.createElement("li");
    var bar = document.createElement("progress"); bar.max = 100; bar.value = 0;
    var label = document.createElement("span"); label.textContent = text;
    li.appendChild(bar); li.appendChild(label);
    document.getElementById("progress").appendChild(li);
    return {li: li, bar: bar, label: label};
  }
  function poll(id, r, name) {
    fetch("/api/logs/" + id, {credentials: "same-origin"}).then(function (resp) { return resp.json(); }).then(function (j) {
      if (j.state === "done" || j.state === "error") {
        var v = j.diagnosis && j.diagnosis.verdict ? j.diagnosis.verdict : {};
        r.label.textContent = name + ": " + (v.status || j.state) + (v.motor ? " (motor " + v.motor + ")" : "") + " ";
        var a = document.createElement("a"); a.href = "/flights/" + id; a.textContent = "open";
        a.className = "flight-link"; a.setAttribute("data-status", v.status || j.state);
        r.label.appendChild(a);
      } else {
        r.label.textContent = name + ": " + j.state + "…";
        setTimeout(function () { poll(id, r, name); }, 1000);
      }
    }).catch(function () { setTimeout(function () { poll(id, r, name); }, 2000); });
  }
  function send(file) {
    var r = row(file.name + ": uploading…");
    var fd = new FormData(); fd.append("log", file, file.name);
    var xhr = new XMLHttpRequest();
    xhr.open("POST", "/api/logs");
    xhr.setRequestHeader("X-CSRF-Token", document.querySelector('meta[name="fdlog-csrf"]').content);
    xhr.upload.onprogress = function (e) { if (e.lengthComputable) r.bar.value = 100 * e.loaded / e.total; };
    xhr.onload = function () {
      var j = {}; try { j = JSON.parse(xhr.responseText); } catch (e) {}
      if (xhr.status === 200) { r.bar.value = 100; r.label.textContent = file.name + ": " + j.state + "…"; poll(j.id, r, file.name); }
      else { r.label.textContent = file.name + ": " + (j.error || ("HTTP " + xhr.status)); r.label.className = "error"; }
    };
    xhr.onerror = function () { r.label.textContent = file.name + ": upload failed"; r.label.className = "error"; };
    xhr.send(fd);
  }
  document.getElementById("upload-form").addEventListener("submit", function (e) { e.preventDefault(); });
  btn.addEventListener("click", function () {
    var files = document.getElementById("files").files;
    for (var i = 0; i < files.length; i++) send(files[i]);
  });
})();
