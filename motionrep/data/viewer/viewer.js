// motionrep viewer: the clips embedded in this page as .glb files, read by three.js's GLTFLoader and drawn as
// skeletons overlaid, with a timeline, the per-frame error curve and the facts of each clip. No network.
(function () {
  "use strict";
  const T = window.MOTIONREP_THREE;
  const data = JSON.parse(document.getElementById("motionrep-data").textContent);
  const $ = (id) => document.getElementById(id);
  const api = (window.motionrepViewer = { ready: false, failed: null });
  const F = data.frames;
  const unit = data.units ? " " + data.units : "";

  function fail(message) {
    api.failed = String(message);
    const box = $("message");
    box.hidden = false;
    box.textContent = "The viewer could not start: " + message;
  }

  function fmt(value, digits) {
    if (value === null || value === undefined || !isFinite(value)) return "-"; // never null, NaN or undefined
    return Number(value).toPrecision(digits || 4).replace(/(\.\d*?)0+(e|$)/, "$1$2").replace(/\.(e|$)/, "$1");
  }

  function percent(value) {
    return data.height > 0 ? fmt((100 * value) / data.height, 3) + "%" : "";
  }

  function decode(b64) {
    const text = atob(b64);
    const bytes = new Uint8Array(text.length);
    for (let i = 0; i < text.length; i++) bytes[i] = text.charCodeAt(i);
    return bytes.buffer;
  }

  // ---- page text ----------------------------------------------------------------------------------------------
  $("title").textContent = data.title;
  for (const clip of data.clips) {
    const item = document.createElement("span");
    const swatch = document.createElement("span");
    swatch.className = "swatch";
    swatch.style.background = clip.color;
    item.append(swatch, clip.name + (clip.role === "reference" ? " (reference)" : ""));
    $("legend").append(item);
  }
  const hasCandidates = data.clips.length > 1;
  // the joints of a candidate are coloured by their error: its own colour when exact, yellow at the scale (the
  // bound, or the largest error of all candidates without one), magenta beyond the bound
  const HOT = "#ffd400";
  const OVER = "#ff00cc";
  let errorScale = data.bound !== null && data.bound > 0 ? data.bound : 0;
  for (const clip of data.clips) if (clip.error && data.bound === null) errorScale = Math.max(errorScale, clip.error.max);
  if (!(errorScale > 0)) errorScale = 1;
  if (hasCandidates) {
    const key = document.createElement("span");
    key.id = "heat-key";
    key.style.color = "#666";
    key.append("joint error: ");
    const ramp = document.createElement("span");
    ramp.className = "ramp";
    ramp.style.background = "linear-gradient(to right, " + data.clips[1].color + ", " + HOT + ")";
    key.append(ramp, " 0 to " + fmt(errorScale, 3) + unit + (data.bound !== null ? " (the bound)" : " (largest)"));
    if (data.bound !== null) {
      const over = document.createElement("span");
      over.className = "swatch";
      over.style.background = OVER;
      key.append(", ", over, "over it");
    }
    $("legend").append(key);
  }
  {
    const note = document.createElement("span");
    note.style.color = "#666";
    note.textContent = "lengths in " + (data.units || "file units") + "; height " + fmt(data.height) + unit;
    $("legend").append(note);
  }

  function factsTable(rows) {
    const table = document.createElement("table");
    for (const [key, value] of rows) {
      const tr = table.insertRow();
      tr.insertCell().textContent = key;
      tr.insertCell().textContent = value;
    }
    return table;
  }

  for (const clip of data.clips) {
    const h = document.createElement("h2");
    h.style.color = clip.color;
    h.textContent = clip.name + (clip.role === "reference" ? " (reference)" : "");
    const rows = [
      ["frames", clip.frames + " at " + clip.rateText + ", " + clip.durationText],
      ["joints", clip.joints + " + " + clip.endSites + " end sites"],
    ];
    if (clip.error) {
      rows.push(["L-inf error", fmt(clip.error.max) + unit + " = " + fmt(clip.error.maxPercent, 3) + "% of height"]);
      rows.push(["worst", "frame " + clip.error.frame + ", " + clip.error.joint]);
      rows.push(["mean error", fmt(clip.error.mean) + unit + " = " + fmt(clip.error.meanPercent, 3) + "%"]);
      if (data.bound !== null) {
        rows.push(["bound", data.boundText + (clip.error.max <= data.bound * (1 + 1e-12) ? " (met)" : " (NOT met)")]);
      }
      if (clip.resampled) rows.push(["note", clip.resampled]);
    }
    $("facts").append(h, factsTable(rows.concat(clip.facts)));
  }

  // ---- the 3D scene -------------------------------------------------------------------------------------------
  const stage = $("stage");
  let renderer;
  try {
    renderer = new T.WebGLRenderer({ antialias: true, preserveDrawingBuffer: true });
  } catch (error) {
    fail("WebGL is not available in this browser (" + error.message + ").");
    return;
  }
  renderer.setPixelRatio(window.devicePixelRatio || 1);
  renderer.outputColorSpace = T.SRGBColorSpace;
  stage.prepend(renderer.domElement);
  const scene = new T.Scene();
  scene.background = new T.Color("#ffffff");
  const camera = new T.PerspectiveCamera(35, 1, 0.01, 1000);
  const controls = new T.OrbitControls(camera, renderer.domElement);
  controls.enableDamping = false;

  const loader = new T.GLTFLoader();
  Promise.all(data.clips.map((clip) => loader.parseAsync(decode(clip.glb), "")))
    .then(start)
    .catch((error) => fail(error && error.message ? error.message : error));

  const tmp = new T.Vector3();
  const up = new T.Vector3(0, 1, 0);

  function skeletonOf(gltf) {
    // the skin's joints, in the file's order (motionrep writes joints then end sites)
    const json = gltf.parser.json;
    return Promise.all(json.skins[0].joints.map((i) => gltf.parser.getDependency("node", i)));
  }

  function tracksOf(gltf, bones) {
    // the animation's values per bone, one key per frame (motionrep samples every frame)
    const byName = new Map(bones.map((b) => [b.name, b]));
    const out = [];
    for (const track of gltf.animations[0].tracks) {
      const dot = track.name.lastIndexOf(".");
      const bone = byName.get(track.name.slice(0, dot));
      const property = track.name.slice(dot + 1);
      if (!bone || (property !== "quaternion" && property !== "position")) continue;
      out.push({ bone, property, times: track.times, values: track.values, width: property === "quaternion" ? 4 : 3 });
    }
    return out;
  }

  function keyIndex(times, t) {
    let lo = 0;
    let hi = times.length - 1;
    while (lo < hi) {
      const mid = (lo + hi + 1) >> 1;
      if (times[mid] <= t + 1e-6) lo = mid;
      else hi = mid - 1;
    }
    return lo;
  }

  const figures = [];
  let radius = 1;

  function makeFigure(clip, gltf, bones, index) {
    scene.add(gltf.scene);
    // the bones to draw, as motionrep chose them (points: joints, then end sites, as the skin lists them)
    const segments = clip.segments.filter(([a, b]) => a < bones.length && b < bones.length);
    const reference = clip.role === "reference";
    const material = new T.MeshBasicMaterial({ color: clip.color });
    if (!reference) {
      material.depthTest = false; // decoded copies are drawn over the reference, never hidden inside it
      material.transparent = true; // (so that they sort after the opaque reference)
    }
    const bonesMesh = new T.InstancedMesh(new T.CylinderGeometry(1, 1, 1, 10, 1, true), material, Math.max(1, segments.length));
    const jointsMesh = new T.InstancedMesh(new T.SphereGeometry(1, 12, 8), material, bones.length);
    bonesMesh.renderOrder = jointsMesh.renderOrder = reference ? 0 : 10 + index;
    bonesMesh.frustumCulled = jointsMesh.frustumCulled = false;
    scene.add(bonesMesh, jointsMesh);
    if (!reference) {
      jointsMesh.material = new T.MeshBasicMaterial({ color: "#ffffff", depthTest: false, transparent: true });
      jointsMesh.setColorAt(0, new T.Color(clip.color)); // makes the per-instance colours
    }
    return { clip, gltf, bones, segments, tracks: tracksOf(gltf, bones), bonesMesh, jointsMesh,
      width: reference ? 1.0 : 0.5, positions: bones.map(() => new T.Vector3()),
      raw: bones.map(() => new T.Vector3()), errors: bones.map(() => 0), colors: bones.map(() => clip.color) };
  }

  let magnification = 1;
  const base = new T.Color();
  const hot = new T.Color(HOT);
  const over = new T.Color(OVER);
  const shade = new T.Color();

  function heat(figure) {
    // per-joint error of a candidate at this frame (true positions, not magnified) and its colour
    const ref = figures[0];
    base.set(figure.clip.color);
    figure.raw.forEach((p, i) => {
      const e = i < ref.raw.length ? p.distanceTo(ref.raw[i]) : 0;
      figure.errors[i] = e;
      const t = e / errorScale;
      if (!$("heat").checked) shade.copy(base);
      else if (data.bound !== null && t > 1 + 1e-9) shade.copy(over);
      else shade.copy(base).lerp(hot, Math.min(1, t));
      figure.colors[i] = "#" + shade.getHexString();
      figure.jointsMesh.setColorAt(i, shade);
    });
    figure.jointsMesh.instanceColor.needsUpdate = true;
  }

  function magnify(figure) {
    // a candidate is drawn at reference + k x its offset from the reference, so a 2 % error can be seen
    const ref = figures[0];
    figure.raw.forEach((p, i) => {
      const r = i < ref.raw.length ? ref.raw[i] : p;
      figure.positions[i].copy(p).sub(r).multiplyScalar(magnification).add(r);
    });
  }

  function pose(figure, frame) {
    const t = frame / data.fps;
    for (const track of figure.tracks) {
      const k = keyIndex(track.times, t) * track.width;
      const v = track.values;
      if (track.width === 4) track.bone.quaternion.set(v[k], v[k + 1], v[k + 2], v[k + 3]);
      else track.bone.position.set(v[k], v[k + 1], v[k + 2]);
    }
    figure.gltf.scene.updateMatrixWorld(true);
    figure.bones.forEach((bone, i) => bone.getWorldPosition(figure.raw[i]));
    figure.positions.forEach((p, i) => p.copy(figure.raw[i]));
  }

  const matrix = new T.Matrix4();
  const quaternion = new T.Quaternion();
  const scale = new T.Vector3();

  function draw(figure) {
    const r = radius * figure.width;
    figure.segments.forEach(([a, b], i) => {
      const pa = figure.positions[a];
      const pb = figure.positions[b];
      tmp.subVectors(pb, pa);
      const length = tmp.length();
      if (length > 0) quaternion.setFromUnitVectors(up, tmp.divideScalar(length));
      else quaternion.identity();
      scale.set(r, Math.max(length, 1e-9), r);
      tmp.addVectors(pa, pb).multiplyScalar(0.5);
      figure.bonesMesh.setMatrixAt(i, matrix.compose(tmp, quaternion, scale));
    });
    const reference = figure.clip.role === "reference";
    figure.positions.forEach((p, i) => {
      // a candidate's joint grows with its error (up to 2.5 times), so the bad ones stand out
      scale.setScalar(r * 1.6 * (reference || !$("heat").checked ? 1 : 1 + 1.5 * Math.min(1, figure.errors[i] / errorScale)));
      figure.jointsMesh.setMatrixAt(i, matrix.compose(p, quaternion.identity(), scale));
    });
    figure.bonesMesh.instanceMatrix.needsUpdate = true;
    figure.jointsMesh.instanceMatrix.needsUpdate = true;
  }

  // ---- time, the curve, the controls --------------------------------------------------------------------------
  let frame = 0;
  let playing = false;
  let last = null;
  let clock = 0;
  const candidates = () => figures.filter((f) => f.clip.role === "candidate");
  const worstFrame = data.clips.length > 1 ? data.clips[1].error.frame : 0;
  const worstFrames = data.clips.slice(1).map((clip) => clip.error.frame);

  // a wire ball around the joint with the largest error of the frame, of the candidate in focus (the first, or
  // the one whose "Worst" button was pressed last)
  let focus = 0;
  const marker = new T.Mesh(new T.SphereGeometry(1, 12, 6),
    new T.MeshBasicMaterial({ color: "#111111", wireframe: true, transparent: true, opacity: 0.7 }));
  marker.renderOrder = 100;
  marker.material.depthTest = false;
  marker.visible = false;

  function seek(f) {
    frame = Math.min(F - 1, Math.max(0, Math.round(f)));
    $("timeline").value = String(frame);
    render();
  }

  function render() {
    for (const figure of figures) pose(figure, frame);
    for (const figure of candidates()) {
      heat(figure);
      magnify(figure);
    }
    for (const figure of figures) draw(figure);
    const lines = ["frame " + frame + " / " + (F - 1) + "   " + (frame / data.fps).toFixed(3) + " s"];
    if (magnification !== 1 && candidates().length) lines.push("error drawn x" + magnification);
    const first = candidates()[focus] || candidates()[0];
    if (first) {
      const j = first.clip.perFrameJoint[frame];
      marker.position.copy(first.positions[Math.min(j, first.positions.length - 1)]);
      marker.scale.setScalar(radius * 7);
      marker.visible = first.clip.perFrame[frame] > 0;
      for (const figure of candidates()) {
        const e = figure.clip.perFrame[frame];
        lines.push(figure.clip.name + ": " + fmt(e, 3) + unit + " (" + percent(e) + ") at " +
          data.pointNames[figure.clip.perFrameJoint[frame]]);
      }
    }
    $("hud").textContent = lines.join("\n");
    // the time of a frame is frame / fps; the clip lasts frames / fps (every frame one frame time)
    $("clock").textContent = "frame " + frame + " / " + (F - 1) + ", " + (frame / data.fps).toFixed(3) + " s of " +
      data.durationText;
    if ($("follow").checked) follow();
    renderer.render(scene, camera);
    drawCurve();
  }

  let centerY = 0;
  const offset = new T.Vector3();
  function follow() {
    // keep the camera where the user put it relative to the character, the character at the centre
    const root = figures[0].positions[0];
    offset.subVectors(camera.position, controls.target);
    controls.target.set(root.x, centerY, root.z);
    camera.position.addVectors(controls.target, offset);
    controls.update();
  }

  const curve = $("curve");
  const margin = { left: 64, right: 70, top: 10, bottom: 22 };
  let curveMax = 0;

  function curveX(f, w) {
    return margin.left + (F > 1 ? (f / (F - 1)) * (w - margin.left - margin.right) : 0);
  }

  function drawCurve() {
    if (!candidates().length) return;
    const ratio = window.devicePixelRatio || 1;
    const w = curve.clientWidth;
    const h = curve.clientHeight;
    if (curve.width !== Math.round(w * ratio)) curve.width = Math.round(w * ratio);
    if (curve.height !== Math.round(h * ratio)) curve.height = Math.round(h * ratio);
    const g = curve.getContext("2d");
    g.setTransform(ratio, 0, 0, ratio, 0, 0);
    g.clearRect(0, 0, w, h);
    g.font = "11px system-ui, sans-serif";
    const plotH = h - margin.top - margin.bottom;
    const y = (v) => margin.top + plotH * (1 - v / (curveMax || 1));
    g.strokeStyle = "#ccc";
    g.fillStyle = "#555";
    g.lineWidth = 1;
    g.beginPath();
    g.moveTo(margin.left, margin.top);
    g.lineTo(margin.left, h - margin.bottom);
    g.lineTo(w - margin.right, h - margin.bottom);
    g.stroke();
    g.textAlign = "right";
    for (const v of [0, curveMax / 2, curveMax]) {
      g.fillText(fmt(v, 3), margin.left - 4, y(v) + 4);
    }
    g.save();
    g.translate(12, margin.top + plotH / 2);
    g.rotate(-Math.PI / 2);
    g.textAlign = "center";
    g.fillText("error (" + (data.units || "file units") + ")", 0, 0);
    g.restore();
    g.textAlign = "left";
    if (data.height > 0) {
      for (const v of [curveMax / 2, curveMax]) g.fillText(percent(v), w - margin.right + 4, y(v) + 4);
      g.fillText("of height", w - margin.right + 4, h - margin.bottom);
    }
    g.textAlign = "center";
    g.fillText("frame", (margin.left + w - margin.right) / 2, h - 4);
    g.textAlign = "left";
    g.fillText("0", margin.left, h - 8);
    g.textAlign = "right";
    g.fillText(String(F - 1), w - margin.right, h - 8);
    if (data.bound !== null) {
      g.strokeStyle = "#b00";
      g.setLineDash([6, 4]);
      g.beginPath();
      g.moveTo(margin.left, y(data.bound));
      g.lineTo(w - margin.right, y(data.bound));
      g.stroke();
      g.setLineDash([]);
      g.fillStyle = "#b00";
      g.textAlign = "left";
      g.fillText("bound " + fmt(data.bound, 3) + unit + (data.height > 0 ? " (" + percent(data.bound) + ")" : ""),
        margin.left + 6, y(data.bound) - 4);
    }
    for (const figure of candidates()) {
      const e = figure.clip.perFrame;
      g.strokeStyle = figure.clip.color;
      g.lineWidth = 1.5;
      g.beginPath();
      e.forEach((v, f) => (f ? g.lineTo(curveX(f, w), y(v)) : g.moveTo(curveX(f, w), y(v))));
      g.stroke();
      const wf = figure.clip.error.frame;
      g.fillStyle = figure.clip.color;
      g.beginPath();
      g.arc(curveX(wf, w), y(e[wf]), 4, 0, 2 * Math.PI);
      g.fill();
    }
    const first = candidates()[focus] || candidates()[0];
    if (first) {
      const wf = first.clip.error.frame;
      g.fillStyle = "#111";
      g.textAlign = curveX(wf, w) > w / 2 ? "right" : "left";
      let labelY = margin.top + 10;
      if (data.bound !== null && Math.abs(y(data.bound) - 4 - labelY) < 12) labelY = y(data.bound) + 14; // not over the bound's
      g.fillText("worst: frame " + wf + ", " + first.clip.error.joint + " " + fmt(first.clip.error.max, 3) + unit,
        curveX(wf, w) + (g.textAlign === "right" ? -8 : 8), labelY);
    }
    g.strokeStyle = "#111";
    g.lineWidth = 1;
    g.beginPath();
    g.moveTo(curveX(frame, w), margin.top);
    g.lineTo(curveX(frame, w), h - margin.bottom);
    g.stroke();
  }

  function seekFromCurve(event) {
    const rect = curve.getBoundingClientRect();
    const x = event.clientX - rect.left;
    const span = rect.width - margin.left - margin.right;
    pause();
    seek(((x - margin.left) / span) * (F - 1));
  }

  function play() {
    if (frame >= F - 1) seek(0);
    playing = true;
    last = null;
    clock = frame;
    $("play").textContent = "Pause";
    requestAnimationFrame(tick);
  }

  function pause() {
    playing = false;
    $("play").textContent = "Play";
  }

  function tick(now) {
    if (!playing) return;
    if (last !== null) {
      clock += ((now - last) / 1000) * data.fps * Number($("speed").value);
      if (clock >= F - 1) {
        seek(F - 1);
        pause();
        return;
      }
      if (Math.floor(clock) !== frame) seek(Math.floor(clock));
    }
    last = now;
    requestAnimationFrame(tick);
  }

  function resize() {
    const w = stage.clientWidth;
    const h = stage.clientHeight;
    renderer.setSize(w, h, false);
    camera.aspect = w / Math.max(1, h);
    camera.updateProjectionMatrix();
    if (figures.length) render();
  }

  function frameTheFigure() {
    // the reference's extent over (a sample of) its frames, in the page's Y-up world, and its own size
    const box = new T.Box3();
    const body = new T.Box3();
    const sizes = [];
    const step = Math.max(1, Math.floor(F / 200));
    for (let f = 0; f < F; f += step) {
      pose(figures[0], f);
      body.makeEmpty();
      figures[0].positions.forEach((p) => body.expandByPoint(p));
      box.union(body);
      sizes.push(body.getSize(new T.Vector3()));
    }
    const size = box.getSize(new T.Vector3());
    const center = box.getCenter(new T.Vector3());
    const median = (values) => values.sort((a, b) => a - b)[values.length >> 1];
    const figure = new T.Vector3(median(sizes.map((s) => s.x)), median(sizes.map((s) => s.y)), median(sizes.map((s) => s.z)));
    const tall = Math.max(figure.x, figure.y, figure.z, 1e-6);
    radius = tall * 0.011;
    // the character as it stands at the start fills about 72 % of the view's height (or of its width)
    pose(figures[0], 0);
    const first = new T.Box3();
    figures[0].positions.forEach((p) => first.expandByPoint(p));
    const startSize = first.getSize(new T.Vector3());
    const startCenter = first.getCenter(new T.Vector3());
    const aspect = Math.max(0.2, camera.aspect || 1);
    const fill = 0.72;
    const viewH = Math.max(startSize.y, (0.75 * Math.max(startSize.x, startSize.z)) / aspect, 0.2 * tall) / fill;
    const distance = viewH / 2 / Math.tan((camera.fov * Math.PI) / 360);
    camera.near = distance / 100;
    camera.far = distance * 20 + Math.max(size.x, size.y, size.z) * 4;
    // a character that moves about more than its own height is followed, so that it stays in that view
    const travels = Math.max(size.x, size.z) > 1.0 * tall;
    centerY = startCenter.y;
    // look across the main direction of travel (a walk is seen from the side), a little from the front and above
    pose(figures[0], 0);
    const start = figures[0].positions[0].clone();
    pose(figures[0], F - 1);
    const along = figures[0].positions[0].clone().sub(start).setY(0);
    const side = new T.Vector3(0.55, 0, 0.8);
    if (along.length() > 0.5 * tall) {
      along.normalize();
      side.set(-along.z, 0, along.x).multiplyScalar(0.9).addScaledVector(along, 0.4);
    }
    side.normalize().multiplyScalar(distance * 0.97);
    controls.target.copy(startCenter);
    camera.position.set(startCenter.x + side.x, startCenter.y + distance * 0.25, startCenter.z + side.z);
    controls.update();
    const span = Math.max(size.x, size.z) + 2 * tall;
    const grid = new T.GridHelper(span, Math.max(4, Math.min(200, Math.round(span / (tall / 2)))), 0xbbbbbb, 0xe2e2e2);
    grid.position.set(center.x, box.min.y, center.z);
    grid.renderOrder = -1;
    scene.add(grid);
    $("follow").checked = travels;
  }

  function start(gltfs) {
    return Promise.all(gltfs.map(skeletonOf)).then((skeletons) => {
      gltfs.forEach((gltf, i) => figures.push(makeFigure(data.clips[i], gltf, skeletons[i], i)));
      scene.add(marker);
      for (const figure of candidates()) curveMax = Math.max(curveMax, ...figure.clip.perFrame);
      if (data.bound !== null) curveMax = Math.max(curveMax, data.bound * 1.1);
      if (!(curveMax > 0)) curveMax = 1;
      $("timeline").max = String(F - 1);
      frameTheFigure();
      if (!candidates().length) {  // one clip: nothing to compare, no error curve
        $("worst").disabled = true;
        curve.style.display = "none";
      }
      // one "Worst frame" button per candidate, in its colour (the first is #worst, the others #worst-2...)
      $("worst").textContent = "Worst frame";
      let previous = $("worst");
      candidates().forEach((figure, i) => {
        const button = i === 0 ? $("worst") : $("worst").cloneNode(false);
        if (i > 0) {
          button.id = "worst-" + (i + 1);
          previous.after(button);
          previous = button;
        }
        button.textContent = "Worst: frame " + worstFrames[i] + (candidates().length > 1 ? " of " + figure.clip.label : "");
        button.title = "Go to the frame where " + figure.clip.name + " has its largest error";
        button.style.borderColor = figure.clip.color;
        button.style.color = figure.clip.color;
        button.addEventListener("click", () => {
          focus = i;
          pause();
          seek(worstFrames[i]);
        });
      });
      $("play").addEventListener("click", () => (playing ? pause() : play()));
      const slider = $("magnify");
      slider.max = String(data.maxMagnification);
      const setMagnification = (k) => {
        magnification = Math.min(data.maxMagnification, Math.max(1, Math.round(Number(k)) || 1));
        slider.value = String(magnification);
        $("magnify-value").textContent = "x" + magnification;
        render();
      };
      slider.addEventListener("input", (e) => setMagnification(e.target.value));
      if (!candidates().length) {
        slider.disabled = true;
        $("heat").disabled = true;
      }
      $("heat").addEventListener("change", render);
      $("timeline").addEventListener("input", (e) => {
        pause();
        seek(Number(e.target.value));
      });
      $("follow").addEventListener("change", render);
      let dragging = false;
      curve.addEventListener("pointerdown", (e) => {
        dragging = true;
        seekFromCurve(e);
      });
      curve.addEventListener("pointermove", (e) => dragging && seekFromCurve(e));
      window.addEventListener("pointerup", () => (dragging = false));
      controls.addEventListener("change", () => renderer.render(scene, camera));
      window.addEventListener("keydown", (e) => {
        if (e.target.tagName === "SELECT" || e.target.tagName === "INPUT" && e.target.type !== "range") return;
        if (e.target.id === "magnify") return; // its own keys change the magnification
        if (e.key === " ") playing ? pause() : play();
        else if (e.key === "ArrowRight") seek(frame + 1);
        else if (e.key === "ArrowLeft") seek(frame - 1);
        else if (e.key === "Home") seek(0);
        else if (e.key === "End") seek(F - 1);
        else return;
        e.preventDefault();
      });
      window.addEventListener("resize", resize);
      resize();
      seek(0);
      Object.assign(api, {
        ready: true,
        three: T.REVISION,
        frames: F,
        worstFrame,
        worstFrames,
        focus: () => focus,
        labels: () => data.clips.map((clip) => clip.name),
        magnification: () => magnification,
        setMagnification,
        frame: () => frame,
        seek: (f) => {
          pause();
          seek(f);
        },
        play,
        pause,
        // world positions (the page's Y-up world) of every bone of clip i at the current frame, as drawn
        // (a candidate magnified) and as the clip has them
        positions: (i) => figures[i].positions.map((p) => [p.x, p.y, p.z]),
        truePositions: (i) => figures[i].raw.map((p) => [p.x, p.y, p.z]),
        jointErrors: (i) => figures[i].errors.slice(),
        jointColors: (i) => figures[i].colors.slice(),
        errorScale,
        // the box of clip i's drawn bones on the screen, in normalised device coordinates (-1..1 fills the view)
        screenBox: (i) => {
          const box = [Infinity, Infinity, -Infinity, -Infinity];
          for (const p of figures[i].positions) {
            const q = p.clone().project(camera);
            box[0] = Math.min(box[0], q.x);
            box[1] = Math.min(box[1], q.y);
            box[2] = Math.max(box[2], q.x);
            box[3] = Math.max(box[3], q.y);
          }
          return box;
        },
        boneNames: (i) => figures[i].bones.map((b) => b.name),
      });
    });
  }
})();
