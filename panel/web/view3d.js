// The 3D view: the arm from ROBOT_MODEL's shapes (one group per DH frame, posed from the link
// frames the panel computes), its set-point ghost, the real arm, the environment's objects and a
// floor grid; OrbitControls for orbit/zoom/pan. World z is up, as in the model.
'use strict';

const View3d = (function () {
  let renderer, scene, camera, controls;
  const arms = {};       // virtual, setpoint, real: arrays of THREE.Group, one per frame
  let envGroup = null, previewGroup = null, pathGroup = null, envKey = '';
  // Drawn only when something changed (a pose, the camera, the scene): a still arm costs nothing,
  // and software rendering (SwiftShader in headless Chromium) keeps up with a moving one.
  let dirty = true;

  function geometryOf(shape) {
    const s = shape.size;
    let g;
    if (shape.type === 'box') {
      g = new THREE.BoxGeometry(s[0], s[1], s[2]);
    } else if (shape.type === 'sphere') {
      g = new THREE.SphereGeometry(s[0], 14, 10);
    } else if (shape.type === 'cylinder') {
      g = new THREE.CylinderGeometry(s[0], s[0], s[1], 16);
      g.rotateX(Math.PI / 2);  // three.js cylinders lie along y; ours along z
    } else {  // capsule: a cylinder and two spheres
      const group = new THREE.Geometry();
      const body = new THREE.CylinderGeometry(s[0], s[0], s[1], 16);
      body.rotateX(Math.PI / 2);
      group.merge(body);
      for (const end of [-0.5, 0.5]) {
        const cap = new THREE.SphereGeometry(s[0], 16, 10);
        cap.translate(0, 0, end * s[1]);
        group.merge(cap);
      }
      g = group;
    }
    return g;
  }

  function meshOf(shape, material) {
    const mesh = new THREE.Mesh(geometryOf(shape), material);
    mesh.position.set(shape.position[0], shape.position[1], shape.position[2]);
    const q = shape.orientation;  // w x y z
    mesh.quaternion.set(q[1], q[2], q[3], q[0]);
    return mesh;
  }

  function materialFor(kind, color) {
    if (kind === 'virtual') {
      return new THREE.MeshLambertMaterial({color: new THREE.Color(color[0], color[1], color[2]),
        transparent: color[3] < 1, opacity: color[3]});
    }
    const c = kind === 'setpoint' ? 0x43a047 : 0xff9800;
    return new THREE.MeshLambertMaterial({color: c, transparent: true,
      opacity: kind === 'setpoint' ? 0.35 : 0.55, depthWrite: false});
  }

  function init(container) {
    // No multisampling and one pixel per CSS pixel: the cost of a frame is its pixels.
    renderer = new THREE.WebGLRenderer({antialias: false, powerPreference: 'high-performance'});
    renderer.setPixelRatio(Math.min(window.devicePixelRatio || 1, 1.5));
    container.appendChild(renderer.domElement);
    scene = new THREE.Scene();
    scene.background = new THREE.Color(0xdfe6ea);
    camera = new THREE.PerspectiveCamera(45, 1, 0.01, 50);
    camera.up.set(0, 0, 1);
    camera.position.set(0.9, -0.9, 0.7);
    controls = new THREE.OrbitControls(camera, renderer.domElement);
    controls.target.set(0, 0, 0.25);
    controls.update();
    controls.addEventListener('change', () => { dirty = true; });
    scene.add(new THREE.HemisphereLight(0xffffff, 0x444444, 0.8));
    const sun = new THREE.DirectionalLight(0xffffff, 0.7);
    sun.position.set(1, -1, 2);
    scene.add(sun);
    const grid = new THREE.GridHelper(2, 20, 0x888888, 0xbbbbbb);
    grid.rotateX(Math.PI / 2);  // the grid lies in x-z; our floor is x-y
    scene.add(grid);
    scene.add(new THREE.AxesHelper(0.15));
    resize(container);
    window.addEventListener('resize', () => resize(container));
  }

  function resize(container) {
    const w = container.clientWidth || 400, h = container.clientHeight || 300;
    renderer.setSize(w, h);
    camera.aspect = w / h;
    camera.updateProjectionMatrix();
    dirty = true;
  }

  // Frees the GPU buffers of a group that leaves the scene.
  function dispose(group) {
    group.traverse((o) => {
      if (o.geometry) o.geometry.dispose();
      if (o.material) o.material.dispose();
    });
  }

  function clearArm(kind) {
    for (const g of arms[kind] || []) { scene.remove(g); dispose(g); }
    arms[kind] = [];
    dirty = true;
  }

  // model: /api/model; builds the three arms, hidden until a state poses them.
  function setModel(model) {
    for (const kind of ['virtual', 'setpoint', 'real']) {
      clearArm(kind);
      model.links.forEach((link) => {
        const group = new THREE.Group();
        for (const shape of link.shapes) group.add(meshOf(shape, materialFor(kind, shape.color)));
        group.visible = false;
        scene.add(group);
        arms[kind].push(group);
      });
    }
  }

  function buildObjects(objects, preview) {
    const group = new THREE.Group();
    for (const o of objects) {
      const c = o.shape.color;
      const material = new THREE.MeshStandardMaterial({color: new THREE.Color(c[0], c[1], c[2]),
        transparent: preview || c[3] < 1, opacity: preview ? 0.4 : c[3], wireframe: preview});
      group.add(meshOf(o.shape, material));
    }
    return group;
  }

  function setEnvironment(env) {
    const key = JSON.stringify(env.objects || []);
    if (envGroup && key === envKey) return;  // the same objects: nothing to rebuild
    envKey = key;
    if (envGroup) { scene.remove(envGroup); dispose(envGroup); }
    envGroup = buildObjects(env.objects || [], false);
    scene.add(envGroup);
    dirty = true;
  }

  function setPreview(objects) {
    dirty = true;
    if (previewGroup) { scene.remove(previewGroup); dispose(previewGroup); }
    previewGroup = objects ? buildObjects(objects, true) : null;
    if (previewGroup) scene.add(previewGroup);
  }

  // A planned path: the tool's points [[x y z] ...] as a line, the waypoints as small balls; null
  // clears it.
  function setPath(points, waypoints) {
    dirty = true;
    if (pathGroup) { scene.remove(pathGroup); dispose(pathGroup); pathGroup = null; }
    if (!points || points.length === 0) return;
    pathGroup = new THREE.Group();
    const line = new THREE.BufferGeometry().setFromPoints(
      points.map((p) => new THREE.Vector3(p[0], p[1], p[2])));
    pathGroup.add(new THREE.Line(line, new THREE.LineBasicMaterial({color: 0xd81b60})));
    const ball = new THREE.SphereGeometry(0.008, 10, 8);
    const material = new THREE.MeshBasicMaterial({color: 0xd81b60});
    for (const w of waypoints || []) {
      const m = new THREE.Mesh(ball, material);
      m.position.set(w[0], w[1], w[2]);
      pathGroup.add(m);
    }
    scene.add(pathGroup);
  }

  // part: {frames: [[x y z qw qx qy qz] ...]} or undefined (hidden)
  function pose(kind, part) {
    const groups = arms[kind] || [];
    dirty = true;
    groups.forEach((g, i) => {
      const f = part && part.frames[i];
      g.visible = !!f;
      if (f) {
        g.position.set(f[0], f[1], f[2]);
        g.quaternion.set(f[4], f[5], f[6], f[3]);
      }
    });
  }

  // Draws the scene if something changed since the last drawing; returns whether it drew.
  function render() {
    controls.update();
    if (!dirty) return false;
    dirty = false;
    renderer.render(scene, camera);
    return true;
  }

  return {init, setModel, setEnvironment, setPreview, setPath, pose, render};
})();
