// SPDX-License-Identifier: MIT
// The avatargw viewer (docs/VIEWER.md): the JSON frames of the daemon's websocket output drawn
// with three.js from Debian's libjs-three, served by the daemon under /three/. Every avatar as a
// lit body (its bones sized from its DESCRIBE), on the floor of avatargw's world (z up, metres),
// with the raw tracker poses as small axes; a card per avatar with its numbers and the last
// minute plotted on a canvas (no chart library). What the page did is in window.avatargwStats
// and, as JSON, in #stats (the tests read them over the DevTools protocol).
import * as THREE from '/three/build/three.module.js';
import { OrbitControls } from '/three/examples/jsm/controls/OrbitControls.js';

const STALE_MS = 500;          // no frame for this long: the avatar is drawn grey, "no frames"
const WINDOW_MS = 2000;        // rates and loss over the last two seconds
const BUCKET_MS = 250;         // the plots: one column per quarter second...
const HISTORY_MS = 60000;      // ...over the last minute
const F_STALE = 1;             // FRAME flag: a sensor is stale or missing
// segments: 0 chest, 1 head, 2-5 right shoulder, elbow, wrist, hand, 6-9 the same on the left
const SENSOR_SEGMENT = [1, 9, 5]; // head, left-hand and right-hand sensors, and what follows them
const SENSOR_NAMES = ['head', 'left hand', 'right hand'];
const SENSOR_SHORT = ['head', 'L hand', 'R hand'];
const STATE_NAMES = ['OK', 'STALE', 'MISSING'];
const PALETTE = [0x4fc3f7, 0xffb74d, 0x81c784, 0xf06292, 0xba68c8, 0xfff176, 0x4db6ac, 0xa1887f];
const GREY = 0x6b6f76;
const OFF_SENSOR_M = 0.02;     // a hand further than this from its sensor is drawn off it, in red
// the body's look where the protocol says nothing (the hips and legs are not tracked)
const TORSO = 0.5;             // shoulder line to hips, m
const LIMB_R = [0.05, 0.042, 0.036]; // radius of the upper arm, forearm, neck
const HEAD_R = 0.1;

const stats = {
	frames: 0,        // messages received
	avatars: 0,       // avatars known
	bodies: 0,        // avatars drawn with a body in the last picture
	meshes: 0,        // visible body meshes in the last picture
	bonesDrawn: 0,    // bones (neck, clavicles, arms, hands) drawn in the last picture
	sensorsDrawn: 0,  // sensor axes drawn in the last picture
	staleAvatars: 0,  // avatars drawn grey in the last picture
	greySensors: 0,   // sensor axes drawn grey (stale or missing, or no frames)
	offSensors: 0,    // hands drawn off their sensor (red) in the last picture
	boneMismatch: 0,  // m: how far an arm bone sized from the DESCRIBE ends from the next joint
	renders: 0,       // pictures drawn
	connected: false,
	connections: 0,   // WebSocket connections opened
	disconnects: 0,   // connections lost
	webgl: false,
	webglError: null, // why there is no 3D view
	glRenderer: '',   // the WebGL renderer's name
	following: null,  // the id of the avatar the camera follows
	errors: [],       // uncaught errors of this page
	list: [],         // per avatar, as in its card
	lastSeq: {},      // avatar id -> the seq of its newest frame
};
window.avatargwStats = stats;
window.addEventListener('error', (e) => stats.errors.push(String(e.message)));
window.addEventListener('unhandledrejection', (e) => stats.errors.push(String(e.reason)));

const $ = (id) => document.getElementById(id);

function finite(a) {
	return Array.isArray(a) && a.every((v) => v !== null && Number.isFinite(v));
}

// ---- the scene (avatargw's world as it is: z up, metres) ----------------------------------------
const view = $('view');
let renderer = null;
{
	// ask first, so that a browser without WebGL gets a clear sentence and no error from three.js
	const probe = document.createElement('canvas');
	let gl = null;
	try {
		gl = probe.getContext('webgl2') || probe.getContext('webgl');
	} catch (e) {
		stats.webglError = e.message;
	}
	if (gl) {
		// a software renderer (SwiftShader, llvmpipe) draws without multisampling: 4 times fewer pixels
		const info = gl.getExtension('WEBGL_debug_renderer_info');
		const name = info ? String(gl.getParameter(info.UNMASKED_RENDERER_WEBGL)) : '';
		stats.glRenderer = name;
		const soft = /swiftshader|llvmpipe|software/i.test(name);
		try {
			renderer = new THREE.WebGLRenderer({ antialias: !soft });
			renderer.setPixelRatio(window.devicePixelRatio);
			view.appendChild(renderer.domElement);
			stats.webgl = true;
		} catch (e) {
			renderer = null;
			stats.webglError = e.message;
		}
	} else if (!stats.webglError) {
		stats.webglError = 'WebGL is not available in this browser (disabled, blocked, or no GPU and no software renderer)';
	}
	if (!renderer) {
		$('glstatus').textContent = 'no 3D view: ' + stats.webglError + '. The numbers and plots still work.';
		$('glstatus').className = 'bad';
		$('nogl').textContent = 'No 3D view: ' + stats.webglError +
			'. The cards on the right still show every avatar.';
		$('nogl').style.display = 'block';
	}
}
const scene = new THREE.Scene();
scene.background = new THREE.Color(0x15181c);
const camera = new THREE.PerspectiveCamera(45, 1, 0.02, 200);
camera.up.set(0, 0, 1);
camera.position.set(1.2, 4, 1.9);
scene.add(new THREE.HemisphereLight(0xdde6f0, 0x30343a, 0.75));
const sun = new THREE.DirectionalLight(0xffffff, 0.75);
sun.position.set(2, 3, 6);
scene.add(sun);
{
	const floor = new THREE.Mesh(new THREE.PlaneBufferGeometry(20, 20),
		new THREE.MeshLambertMaterial({ color: 0x1e2228 }));
	scene.add(floor);
	const grid = new THREE.GridHelper(10, 20, 0x4a5462, 0x2e343c); // 10 m, 0.5 m squares
	grid.rotation.x = Math.PI / 2; // three's grid lies in x-z: turn it onto the floor, z = 0
	grid.position.z = 0.001;
	scene.add(grid);
	const axes = new THREE.AxesHelper(0.5); // x red, y green, z blue: avatargw's own axes
	axes.position.z = 0.002;
	scene.add(axes);
}
let controls = null;
let autoFrame = true; // the camera frames the people present until the user moves it
let dirty = true;     // the camera moved, or the window changed: draw a picture
let moving = false;   // the page itself moves the camera
if (renderer) {
	controls = new OrbitControls(camera, renderer.domElement); // built after camera.up: orbits about z
	controls.target.set(0, 0, 1);
	controls.enableDamping = false;
	controls.addEventListener('start', () => {
		autoFrame = false;
	});
	controls.addEventListener('change', () => {
		dirty = dirty || !moving; // the user's move; the page's own (framing, following) is drawn already
	});
}
function resize() {
	const w = Math.max(1, view.clientWidth);
	const h = Math.max(1, view.clientHeight);
	camera.aspect = w / h;
	camera.updateProjectionMatrix();
	if (renderer)
		renderer.setSize(w, h);
	dirty = true;
}
window.addEventListener('resize', resize);
resize();

// shared shapes: a unit cylinder along y, a unit sphere, a unit box
const CYL = new THREE.CylinderBufferGeometry(1, 1, 1, 16, 1);
const SPHERE = new THREE.SphereBufferGeometry(1, 18, 12);
const BOX = new THREE.BoxBufferGeometry(1, 1, 1);
const Y = new THREE.Vector3(0, 1, 0);
const tv = [new THREE.Vector3(), new THREE.Vector3(), new THREE.Vector3(), new THREE.Vector3()];
const tq = new THREE.Quaternion();

function vec(p, out) {
	return out.set(p[0], p[1], p[2]);
}

function quat(p, out) {
	return out.set(p[4], p[5], p[6], p[3]); // the wire's w, x, y, z -> three's x, y, z, w
}

// a cylinder from a to b, radius r
function place(mesh, a, b, r) {
	const d = tv[3].subVectors(b, a);
	const len = d.length();
	mesh.visible = len > 1e-4;
	if (!mesh.visible)
		return;
	mesh.position.addVectors(a, b).multiplyScalar(0.5);
	mesh.quaternion.setFromUnitVectors(Y, d.divideScalar(len));
	mesh.scale.set(r, len, r);
}

function label(text) {
	const c = document.createElement('canvas');
	c.width = 512;
	c.height = 80;
	const g = c.getContext('2d');
	g.font = '600 34px system-ui, sans-serif';
	g.textAlign = 'center';
	g.fillStyle = 'rgba(20, 22, 26, 0.7)';
	const w = Math.min(500, g.measureText(text).width + 28);
	g.fillRect(256 - w / 2, 12, w, 54);
	g.fillStyle = '#eef';
	g.fillText(text, 256, 52);
	const s = new THREE.Sprite(new THREE.SpriteMaterial({ map: new THREE.CanvasTexture(c), depthTest: false }));
	s.scale.set(0.8, 0.125, 1);
	s.renderOrder = 10;
	return s;
}

// ---- avatars --------------------------------------------------------------------------------
const avatars = new Map(); // id -> drawn avatar
let following = null;      // the avatar the camera follows, or null

function title(av) {
	return (av.name || 'avatar ' + av.id) + (av.site ? ' · ' + av.site : '');
}

function makeBody(av) {
	const color = av.color;
	av.mat = new THREE.MeshLambertMaterial({ color });
	av.trunkMat = new THREE.MeshLambertMaterial({ color: color.clone().multiplyScalar(0.78) });
	av.legMat = new THREE.MeshLambertMaterial({ color, transparent: true, opacity: 0.35 });
	const offMat = new THREE.MeshBasicMaterial({ color: 0xff3d3d });
	const mesh = (geo, mat) => {
		const m = new THREE.Mesh(geo, mat);
		m.userData.avatar = av.id;
		av.group.add(m);
		return m;
	};
	av.body = {
		trunk: mesh(CYL, av.trunkMat),
		head: mesh(SPHERE, av.mat),
		visor: mesh(BOX, av.trunkMat),
		neck: mesh(CYL, av.mat),
		// per side (0 right, 1 left): clavicle, upper arm, forearm, hand, and joints
		clav: [mesh(CYL, av.mat), mesh(CYL, av.mat)],
		upper: [mesh(CYL, av.mat), mesh(CYL, av.mat)],
		fore: [mesh(CYL, av.mat), mesh(CYL, av.mat)],
		hand: [mesh(BOX, av.mat), mesh(BOX, av.mat)],
		joints: [0, 1, 2, 3, 4, 5].map(() => mesh(SPHERE, av.mat)), // shoulders, elbows, wrists
		legs: [mesh(CYL, av.legMat), mesh(CYL, av.legMat)],
		hips: mesh(CYL, av.legMat),
		// a hand off its sensor: a red rod from the sensor to the solved hand, and a red ball on the sensor
		offRod: [mesh(CYL, offMat), mesh(CYL, offMat)],
		offBall: [mesh(SPHERE, offMat), mesh(SPHERE, offMat)],
	};
	av.shadow = new THREE.Mesh(new THREE.CircleBufferGeometry(0.32, 32),
		new THREE.MeshBasicMaterial({ color: 0x000000, transparent: true, opacity: 0.35, depthWrite: false }));
	av.shadow.position.z = 0.003;
	av.group.add(av.shadow);
	av.sensors = [];
	for (let s = 0; s < 3; s++) {
		const a = new THREE.AxesHelper(s === 0 ? 0.14 : 0.1);
		a.visible = false;
		av.group.add(a);
		av.sensors.push(a);
	}
}

function makeAvatar(rec) {
	const av = {
		id: rec.id, name: rec.name || '', site: rec.site || '', // site: another site's people ([site])
		siteStats: null, // how that site's samples reach the daemon: rate, loss, delay, clock
		color: new THREE.Color(PALETTE[avatars.size % PALETTE.length]),
		group: new THREE.Group(), rec: null, rx: -1e9, hist: [], buckets: [], bucket: null,
		drawnSeq: -1, drawn: [], since: performance.now(), latency: null, card: null, grey: null,
	};
	makeBody(av);
	av.tag = label(title(av));
	av.group.add(av.tag);
	scene.add(av.group);
	avatars.set(av.id, av);
	makeCard(av);
	return av;
}

// the segment's own axis (in its frame) times a length from the DESCRIBE, from its origin
function along(seg, axis, len, out) {
	quat(seg, tq);
	out.copy(axis).applyQuaternion(tq).multiplyScalar(len);
	return out.add(vec(seg, tv[2]));
}

const CYL_UP = new THREE.Quaternion().setFromAxisAngle(new THREE.Vector3(1, 0, 0), Math.PI / 2); // y -> z
const AX_UPPER = new THREE.Vector3(0, 0, -1); // r/l_shoulder: -z runs down the upper arm
const AX_FORE = new THREE.Vector3(0, 1, 0);   // r/l_elbow, r/l_wrist: +y along the forearm and hand

function setGrey(av, grey) {
	if (av.grey === grey)
		return;
	av.grey = grey;
	const c = grey ? GREY : av.color;
	av.mat.color.set(c);
	av.trunkMat.color.set(grey ? 0x5a5e64 : new THREE.Color(c).multiplyScalar(0.78));
	av.legMat.color.set(c);
	av.tag.material.color.set(grey ? 0x9a9ea6 : 0xffffff);
}

// the body of the newest frame; returns what it drew
function draw(av, now) {
	const rec = av.rec;
	const B = av.body;
	const seg = rec.segments;
	const noFrames = now - av.rx > STALE_MS;
	const stale = noFrames || (rec.flags & F_STALE) !== 0;
	const dims = finite(rec.dims) ? rec.dims : null;
	const out = { bones: 0, sensors: 0, stale, grey: 0, off: 0, meshes: 0, body: false, mismatch: 0 };
	setGrey(av, stale);
	const ok = finite(seg[0]) && [2, 3, 4, 6, 7, 8].every((i) => finite(seg[i]));
	for (const m of av.group.children)
		if (m.isMesh && m !== av.shadow)
			m.visible = false;
	av.shadow.visible = false;
	if (ok) {
		out.body = true;
		const chest = vec(seg[0], new THREE.Vector3());
		const qc = quat(seg[0], new THREE.Quaternion());
		const up = new THREE.Vector3(0, 0, 1).applyQuaternion(qc);
		// the trunk: a box below the shoulder line, as wide as the shoulders, turned as the chest
		const shoulderW = dims ? 2 * dims[0] : vec(seg[2], tv[0]).distanceTo(vec(seg[6], tv[1]));
		B.trunk.visible = true;
		B.trunk.quaternion.copy(qc).multiply(CYL_UP); // an elliptic cylinder along the chest's z
		B.trunk.scale.set(Math.max(0.1, shoulderW * 0.46), TORSO, 0.11);
		B.trunk.position.copy(chest).addScaledVector(up, -TORSO / 2 + 0.03);
		// the hips and the legs, straight down to the floor: drawn, not tracked
		const hips = chest.clone().addScaledVector(up, -TORSO);
		if (hips.z > 0.35) {
			const side = new THREE.Vector3(1, 0, 0).applyQuaternion(qc);
			side.z = 0;
			side.normalize().multiplyScalar(0.1);
			const lh = hips.clone().sub(side);
			const rh = hips.clone().add(side);
			place(B.hips, lh, rh, 0.075);
			place(B.legs[0], rh, new THREE.Vector3(rh.x, rh.y, 0.04), 0.065);
			place(B.legs[1], lh, new THREE.Vector3(lh.x, lh.y, 0.04), 0.065);
		}
		av.shadow.visible = true;
		av.shadow.position.set(chest.x, chest.y, 0.003);
		// the head: the head segment is the head sensor; the ball sits on the neck above the chest
		if (finite(seg[1])) {
			const hs = vec(seg[1], new THREE.Vector3());
			const d = hs.clone().sub(chest);
			const lift = Math.max(d.length(), 0.26);
			const dir = d.length() > 1e-3 ? d.normalize() : up.clone();
			const centre = chest.clone().addScaledVector(dir, lift);
			place(B.neck, chest, centre, LIMB_R[2]);
			B.head.visible = true;
			B.head.position.copy(centre);
			B.head.scale.setScalar(HEAD_R);
			// a visor in front of the head, where the head sensor looks (its +y)
			const qh = quat(seg[1], new THREE.Quaternion());
			B.visor.visible = true;
			B.visor.quaternion.copy(qh);
			B.visor.position.copy(centre).add(new THREE.Vector3(0, HEAD_R * 0.85, 0.01).applyQuaternion(qh));
			B.visor.scale.set(0.13, 0.05, 0.05);
			out.bones++;
		}
		// the arms: each bone from its segment's origin along its own axis, as long as the DESCRIBE says
		for (let side = 0; side < 2; side++) {
			const [sh, el, wr, ha] = side === 0 ? [2, 3, 4, 5] : [6, 7, 8, 9];
			const pS = vec(seg[sh], new THREE.Vector3());
			const pE = vec(seg[el], new THREE.Vector3());
			const pW = vec(seg[wr], new THREE.Vector3());
			place(B.clav[side], chest, pS, LIMB_R[1] * 0.9);
			const eEnd = dims ? along(seg[sh], AX_UPPER, dims[1], new THREE.Vector3()) : pE;
			const wEnd = dims ? along(seg[el], AX_FORE, dims[2], new THREE.Vector3()) : pW;
			// the DESCRIBE's lengths along the segments' axes end where the next joints are
			out.mismatch = Math.max(out.mismatch, eEnd.distanceTo(pE), wEnd.distanceTo(pW));
			place(B.upper[side], pS, eEnd, LIMB_R[0]);
			place(B.fore[side], pE, wEnd, LIMB_R[1]);
			[pS, pE, pW].forEach((p, k) => {
				const j = B.joints[side * 3 + k];
				j.visible = true;
				j.position.copy(p);
				j.scale.setScalar(k === 0 ? 0.058 : k === 1 ? 0.048 : 0.04);
			});
			// the hand: a flat box from the wrist along the hand's +y
			const hl = dims && dims[3] > 0.05 ? dims[3] : 0.09;
			const h = B.hand[side];
			h.visible = true;
			quat(seg[wr], h.quaternion);
			h.position.copy(pW).add(new THREE.Vector3(0, hl / 2, 0).applyQuaternion(h.quaternion));
			h.scale.set(0.075, hl, 0.028);
			out.bones += 4; // clavicle, upper arm, forearm, hand
		}
	}
	// the raw sensors; a hand further than OFF_SENSOR_M from its sensor gets a red rod and ball
	rec.sensors.forEach((s, i) => {
		const a = av.sensors[i];
		const p = s.pose;
		a.visible = finite(p);
		if (!a.visible)
			return;
		vec(p, a.position);
		quat(p, a.quaternion);
		const dim = noFrames || s.state !== 0; // the sensor that dropped out, not its fellows
		const vc = dim ? THREE.NoColors : THREE.VertexColors;
		if (a.material.vertexColors !== vc) {
			a.material.vertexColors = vc;
			a.material.color.set(dim ? GREY : 0xffffff);
			a.material.needsUpdate = true;
		}
		out.grey += dim ? 1 : 0;
		out.sensors++;
		if (i > 0 && finite(seg[SENSOR_SEGMENT[i]])) {
			const side = i === 2 ? 0 : 1;
			const sp = vec(p, new THREE.Vector3());
			const hp = vec(seg[SENSOR_SEGMENT[i]], new THREE.Vector3());
			if (sp.distanceTo(hp) > OFF_SENSOR_M) {
				place(av.body.offRod[side], sp, hp, 0.008);
				av.body.offBall[side].visible = true;
				av.body.offBall[side].position.copy(sp);
				av.body.offBall[side].scale.setScalar(0.022);
				out.off++;
			}
		}
	});
	const top = finite(seg[1]) ? seg[1] : seg[0];
	if (finite(top))
		av.tag.position.set(top[0], top[1], Math.max(top[2], finite(seg[0]) ? seg[0][2] + 0.26 : 0) + 0.25);
	av.tag.visible = finite(top);
	for (const m of av.group.children)
		if (m.isMesh && m.visible && m !== av.shadow)
			out.meshes++;
	return out;
}

// ---- the camera: frame the people present, or follow one ------------------------------------
let followPrev = null;

function present(now) {
	return [...avatars.values()].filter((av) => av.rec && finite(av.rec.segments[0]) && now - av.rx < 10000);
}

function frameAll(now, snap) {
	const list = present(now);
	if (!list.length)
		return;
	const box = new THREE.Box3();
	const facing = new THREE.Vector3();
	for (const av of list) {
		const c = av.rec.segments[0];
		box.expandByPoint(new THREE.Vector3(c[0], c[1], 0));
		box.expandByPoint(new THREE.Vector3(c[0], c[1], Math.max(1.9, c[2] + 0.4)));
		facing.add(new THREE.Vector3(0, 1, 0).applyQuaternion(quat(c, tq)));
	}
	const centre = box.getCenter(new THREE.Vector3());
	const size = box.getSize(new THREE.Vector3());
	const radius = 0.5 * Math.hypot(size.x + 1.0, size.y + 1.0, size.z);
	const fov = camera.fov * Math.PI / 180 / 2;
	const dist = radius / Math.sin(Math.min(fov, Math.atan(Math.tan(fov) * camera.aspect))) * 1.05;
	facing.z = 0;
	if (facing.lengthSq() < 1e-6)
		facing.set(0, 1, 0);
	facing.normalize();
	const right = new THREE.Vector3(facing.y, -facing.x, 0);
	// in front of the people, a little to their right and above
	const dir = facing.clone().add(right.multiplyScalar(0.35)).add(new THREE.Vector3(0, 0, 0.3)).normalize();
	const want = centre.clone();
	const wantCam = want.clone().addScaledVector(dir, dist);
	const k = snap ? 1 : 0.08;
	controls.target.lerp(want, k);
	camera.position.lerp(wantCam, k);
	moving = true;
	controls.update();
	moving = false;
}

function follow() {
	const av = following;
	if (!av.rec || !finite(av.rec.segments[0]))
		return;
	const c = av.rec.segments[0];
	const p = new THREE.Vector3(c[0], c[1], Math.max(0.9, c[2] - 0.35));
	if (followPrev) {
		const d = p.clone().sub(followPrev);
		controls.target.add(d);
		camera.position.add(d);
	} else {
		// the first picture of it: move the target onto it, from where the camera looks now
		const off = camera.position.clone().sub(controls.target);
		if (off.length() > 4)
			off.setLength(4);
		controls.target.copy(p);
		camera.position.copy(p).add(off);
	}
	followPrev = p;
	moving = true;
	controls.update();
	moving = false;
}

function forget(av) {
	if (following === av)
		setFollowing(null);
	scene.remove(av.group);
	av.tag.material.map.dispose();
	av.card.el.remove();
	avatars.delete(av.id);
	stats.avatars = avatars.size;
}

function setFollowing(av) {
	following = av;
	followPrev = null;
	stats.following = av ? av.id : null;
	autoFrame = !av;
	for (const a of avatars.values())
		a.card.el.classList.toggle('following', a === av);
}

// where an avatar's chest is on the screen, in CSS pixels of the page (for tests that click it), or null
window.avatargwProject = (id) => {
	const av = avatars.get(id);
	if (!renderer || !av || !av.body.trunk.visible)
		return null;
	const p = av.body.trunk.position.clone().project(camera);
	const r = renderer.domElement.getBoundingClientRect();
	return [r.left + (p.x + 1) / 2 * r.width, r.top + (1 - p.y) / 2 * r.height];
};

$('frameall').addEventListener('click', () => setFollowing(null));
window.addEventListener('keydown', (e) => {
	if (e.key === 'f' || e.key === 'F')
		setFollowing(null);
});

if (renderer) {
	// a click (not a drag) on a body follows it
	const ray = new THREE.Raycaster();
	let down = null;
	renderer.domElement.addEventListener('pointerdown', (e) => {
		down = [e.clientX, e.clientY];
	});
	renderer.domElement.addEventListener('pointerup', (e) => {
		if (!down || Math.hypot(e.clientX - down[0], e.clientY - down[1]) > 5)
			return;
		const r = renderer.domElement.getBoundingClientRect();
		ray.setFromCamera(new THREE.Vector2((e.clientX - r.left) / r.width * 2 - 1,
			-(e.clientY - r.top) / r.height * 2 + 1), camera);
		const hits = ray.intersectObjects([...avatars.values()].map((a) => a.group), true)
			.filter((h) => h.object.userData.avatar !== undefined && h.object.visible);
		if (hits.length)
			setFollowing(avatars.get(hits[0].object.userData.avatar));
	});
}

// ---- the numbers and the last minute ----------------------------------------------------------
function fmt(v, digits) {
	return v === null || v === undefined || !Number.isFinite(v) ? '–' : v.toFixed(digits);
}

// over the last WINDOW_MS: rate (the daemon's, from seq on its clock), received and drawn frames
// per second of wall time, loss (from k gaps); shown never above what the output sends
function windowStats(av, now) {
	av.hist = av.hist.filter((h) => now - h[0] <= WINDOW_MS);
	av.drawn = av.drawn.filter((t) => now - t <= WINDOW_MS);
	const h = av.hist;
	const out = { rate: null, outRate: null, received: null, shown: null, loss: null };
	if (h.length >= 2) {
		const first = h[0];
		const last = h[h.length - 1];
		const dsend = (last[3] - first[3]) / 1000; // the daemon's clock: bursts in arrival do not count
		const dseq = (last[1] - first[1]) >>> 0;
		const dk = last[2] - first[2];
		if (dsend > 0) {
			out.rate = dseq / dsend;
			out.outRate = dk / dsend; // texts carrying it that the output sent per second
		}
		if (dk > 0)
			out.loss = Math.max(0, 100 * (dk - (h.length - 1)) / dk);
	}
	const span = Math.min(WINDOW_MS, now - av.since) / 1000;
	if (span > 0.5) {
		out.received = h.length / span;
		out.shown = renderer ? av.drawn.length / span : null;
		if (out.outRate !== null)
			out.shown = Math.min(out.shown, out.outRate);
	}
	return out;
}

// one column of the plots per BUCKET_MS: rate, loss, latency, IK error, the worst state of each sensor
function bucketTick(av, now, st) {
	const b = av.bucket || { n: 0, lat: null, ik: null, states: [-1, -1, -1] };
	const prev = av.buckets.length ? av.buckets[av.buckets.length - 1] : null;
	b.t = now;
	// live: frames are coming (a quarter second without one, in a burst of a starved browser, is not
	// a dropout: the sensors keep the states they had); a dropout breaks the lines and darkens the strip
	b.live = now - av.rx <= STALE_MS;
	b.rate = b.live ? st.rate : null;
	b.loss = b.live ? st.loss : null;
	if (!b.n && b.live && prev)
		b.states = prev.states.slice();
	av.buckets.push(b);
	while (av.buckets.length && now - av.buckets[0].t > HISTORY_MS)
		av.buckets.shift();
	av.bucket = null;
}

function bucketAdd(av, rec, latency) {
	const b = av.bucket || (av.bucket = { n: 0, lat: null, ik: null, states: [-1, -1, -1] });
	b.n++;
	if (Number.isFinite(latency))
		b.lat = b.lat === null ? latency : Math.max(b.lat, latency);
	const ik = rec.ik_err.filter((e) => e !== null && Number.isFinite(e));
	if (ik.length)
		b.ik = Math.max(b.ik === null ? 0 : b.ik, 1000 * Math.max(...ik));
	rec.sensors.forEach((s, i) => {
		b.states[i] = Math.max(b.states[i], s.state);
	});
}

function makeCard(av) {
	const el = document.createElement('div');
	el.className = 'card';
	el.innerHTML = '<div class="head"><span class="swatch"></span><span class="name"></span><span class="site"></span>' +
		'<span class="id"></span><span class="state"></span></div><div class="nums"></div><div class="nums sitenums"></div><canvas width="676" height="316"></canvas>';
	el.addEventListener('click', () => setFollowing(following === av ? null : av));
	$('avatars').appendChild(el);
	av.card = { el, swatch: el.querySelector('.swatch'), name: el.querySelector('.name'), site: el.querySelector('.site'),
		id: el.querySelector('.id'), state: el.querySelector('.state'), nums: el.querySelector('.nums'),
		siteNums: el.querySelector('.sitenums'), canvas: el.querySelector('canvas') };
}

function updateCard(av, now, st, grey) {
	const r = av.rec;
	const c = av.card;
	c.swatch.style.background = '#' + (grey ? GREY : av.color.getHex()).toString(16).padStart(6, '0');
	c.name.textContent = av.name || 'avatar';
	c.site.textContent = av.site ? '@ ' + av.site : '';
	c.id.textContent = '#' + av.id;
	// 'ok', or which sensors are stale or missing: "stale: head, L hand"
	const bad = [1, 2].map((st) => r.sensors.map((s, i) => (s.state === st ? SENSOR_SHORT[i] : '')).filter((x) => x))
		.map((names, k) => (names.length ? STATE_NAMES[k + 1].toLowerCase() + ': ' + names.join(', ') : ''))
		.filter((x) => x);
	const noFrames = now - av.rx > STALE_MS;
	c.state.textContent = noFrames ? 'no frames' : bad.length ? bad.join('; ') : 'ok';
	c.state.className = 'state ' + (noFrames ? 'bad' : bad.length ? 'warn' : 'ok');
	const latency = av.latency;
	const ik = r.ik_err.map((e) => fmt(e === null ? null : e * 1000, 1)).join(' / ');
	c.nums.innerHTML = '<span title="frames the daemon publishes per second">rate <b>' + fmt(st.rate, 0) + '</b> Hz</span>' +
		'<span title="frames this page drew per second of wall time (never above what the output sends)">shown <b>' +
		fmt(st.shown, 0) + '</b> Hz</span>' +
		'<span title="frames sent to this page that did not arrive">loss <b>' + fmt(st.loss, 1) + '</b> %</span>' +
		'<span title="this computer\'s clock minus the newest tracker sample\'s time: needs synchronised clocks">latency <b>' +
		fmt(latency, 1) + '</b> ms</span>' +
		'<span title="from the tracker sample to the daemon sending it here">daemon <b>' + fmt(r.srv_ms, 1) + '</b> ms</span>' +
		'<span title="distance from each hand sensor to the solved hand, right / left">IK <b>' + ik + '</b> mm</span>';
	c.siteNums.innerHTML = siteLine(av.site, av.siteStats);
	plot(av, now);
}

function escapeHtml(t) {
	return String(t).replace(/[&<>"']/g, (c) => '&#' + c.charCodeAt(0) + ';');
}

// another site's avatar: how its site's samples reach the daemon (docs/SITES.md), or nothing
function siteLine(site, f) {
	if (!f)
		return '';
	const ms = (v) => (v === null || v < 0 ? '–' : fmt(v, 1));
	return '<span title="the remote site, as the daemon sees it">' + escapeHtml(site) + ' <b>' + escapeHtml(f.state) + '</b></span>' +
		'<span title="frames a second from that site, all its avatars">site rate <b>' + fmt(f.rate_hz, 0) + '</b> Hz</span>' +
		'<span title="samples of that site lost on the network">lost <b>' + f.lost + '</b></span>' +
		'<span title="one way, its sample time (on this daemon\'s clock) to the arrival here, p50 / p99">delay <b>' +
		ms(f.delay_p50_ms) + ' / ' + ms(f.delay_p99_ms) + '</b> ms</span>' +
		'<span title="its clock minus the daemon\'s, estimated from a round trip">clock <b>' +
		(f.rtt_ms === null || f.rtt_ms < 0 ? '–' : fmt(f.clock_offset_ms, 2)) + '</b> ms</span>' +
		'<span title="round trip to that site">rtt <b>' + ms(f.rtt_ms) + '</b> ms</span>';
}

// the last minute on the card's canvas: four line plots and the sensor strip
function plot(av, now) {
	const cv = av.card.canvas;
	const g = cv.getContext('2d');
	const W = cv.width;
	const H = cv.height;
	const s = W / 338; // the canvas has twice the pixels of its box, for sharp lines
	g.setTransform(s, 0, 0, s, 0, 0);
	const w = W / s;
	const L = 62; // left margin, labels
	const R = 4;
	const pw = w - L - R;
	g.fillStyle = '#15181c';
	g.fillRect(0, 0, w, H / s);
	g.font = '10px system-ui, sans-serif';
	g.textBaseline = 'middle';
	const x = (t) => L + pw * (1 - (now - t) / HISTORY_MS);
	const rows = [
		{ name: 'rate Hz', key: 'rate', color: '#4fc3f7', min: 10 },
		{ name: 'loss %', key: 'loss', color: '#f06292', min: 5 },
		{ name: 'latency ms', key: 'lat', color: '#ffb74d', min: 20 },
		{ name: 'IK err mm', key: 'ik', color: '#ba68c8', min: 5 },
	];
	const rowH = 28;
	let y0 = 2;
	for (const row of rows) {
		const vals = av.buckets.map((b) => b[row.key]).filter((v) => v !== null && Number.isFinite(v));
		const max = Math.max(row.min, ...vals) * 1.25;
		g.fillStyle = '#1d2127';
		g.fillRect(L, y0, pw, rowH - 4);
		// the name, the newest value in the line's colour, and the scale's top inside the plot
		const cur = av.buckets.length ? av.buckets[av.buckets.length - 1][row.key] : null;
		g.textAlign = 'left';
		g.fillStyle = '#99a';
		g.fillText(row.name, 2, y0 + 7);
		g.fillStyle = row.color;
		g.fillText(fmt(cur, cur !== null && cur < 10 ? 1 : 0), 2, y0 + 18);
		g.fillStyle = '#667';
		g.fillText(fmt(max, max < 10 ? 1 : 0), L + 2, y0 + 6);
		g.strokeStyle = row.color;
		g.lineWidth = 1.2;
		g.beginPath();
		let pen = false;
		for (const b of av.buckets) {
			const v = b[row.key];
			if (!b.live)
				pen = false;
			if (v === null || !Number.isFinite(v))
				continue;
			const px = x(b.t);
			const py = y0 + (rowH - 5) * (1 - Math.min(v, max) / max) + 0.5;
			if (pen)
				g.lineTo(px, py);
			else
				g.moveTo(px, py);
			pen = true;
		}
		g.stroke();
		y0 += rowH;
	}
	// the sensor strip: OK green, STALE amber, MISSING red, no frames dark
	const SC = { '-1': '#2a2e35', 0: '#43a047', 1: '#ffa000', 2: '#e53935' };
	const sh = 9;
	for (let i = 0; i < 3; i++) {
		g.fillStyle = '#99a';
		g.fillText(SENSOR_SHORT[i], 2, y0 + sh / 2);
		g.fillStyle = SC[-1];
		g.fillRect(L, y0, pw, sh - 1);
		let t0 = null;
		for (const b of av.buckets) {
			// from the column before (a starved browser ticks later than every BUCKET_MS) to this one
			const x0 = Math.max(L, x(t0 === null || b.t - t0 > 4 * BUCKET_MS ? b.t - BUCKET_MS : t0));
			g.fillStyle = SC[b.states[i]];
			g.fillRect(x0, y0, x(b.t) - x0 + 0.6, sh - 1);
			t0 = b.t;
		}
		y0 += sh;
	}
	// the time axis: a tick every 10 s
	g.fillStyle = '#778';
	g.textAlign = 'center';
	for (let t = 0; t <= 60; t += 10) {
		const px = L + pw * (1 - t / 60);
		g.fillRect(px, 2, 0.6, y0 - 2);
		g.fillText(t ? '-' + t + ' s' : 'now', Math.min(px, w - 12), y0 + 7);
	}
}

// ---- the connection -------------------------------------------------------------------------
let lastGen = 0;

function onFrames(msg) {
	const now = performance.now();
	stats.frames++;
	// a restarted daemon (or output) counts from 1 again: start the windows afresh
	const restart = msg.gen < lastGen;
	lastGen = msg.gen;
	for (const rec of msg.avatars) {
		let av = avatars.get(rec.id);
		if (!av)
			av = makeAvatar(rec);
		if ((rec.name && rec.name !== av.name) || (rec.site || '') !== av.site) {
			av.name = rec.name || av.name;
			av.site = rec.site || '';
			av.group.remove(av.tag);
			av.tag.material.map.dispose();
			av.tag.material.dispose();
			av.tag = label(title(av));
			av.group.add(av.tag);
		}
		av.siteStats = rec.site_stats || null;
		if (restart || (av.rec && rec.k <= av.rec.k) || now - av.rx > WINDOW_MS) {
			av.hist = [];
			av.drawn = [];
			av.since = now;
		}
		av.rec = rec;
		av.rx = now;
		av.latency = Date.now() - rec.t;
		av.hist.push([now, rec.seq, rec.k, msg.t]);
		bucketAdd(av, rec, av.latency);
		stats.lastSeq[rec.id] = rec.seq;
	}
	stats.avatars = avatars.size;
}

let attempts = 0;
function connect() {
	const status = $('status');
	const ws = new WebSocket((location.protocol === 'https:' ? 'wss://' : 'ws://') + location.host + '/', 'avatargw-json');
	let opened = false;
	ws.onopen = () => {
		opened = true;
		attempts = 0;
		stats.connected = true;
		stats.connections++;
		status.className = '';
		status.textContent = 'connected to ' + location.host + (stats.connections > 1 ? ' (again, after ' + stats.disconnects + ' lost)' : '');
	};
	ws.onmessage = (ev) => {
		let msg;
		try {
			msg = JSON.parse(ev.data);
		} catch (e) {
			stats.errors.push('bad JSON from the daemon: ' + e.message);
			return;
		}
		if (msg.type === 'frames')
			onFrames(msg);
	};
	ws.onclose = () => {
		if (opened)
			stats.disconnects++;
		stats.connected = false;
		attempts++;
		status.className = 'lost';
		status.textContent = (stats.connections ? 'connection lost at ' + new Date().toLocaleTimeString() : 'cannot connect') +
			': trying again' + (attempts > 1 ? ' (' + attempts + ')' : '') + '…';
		setTimeout(connect, Math.min(1000 * attempts, 3000));
	};
}
connect();

// ---- the picture ----------------------------------------------------------------------------
// A picture is drawn when there is something new to show: a frame, a moved camera, or a quarter
// second gone by (an avatar turning grey); a software renderer is not kept busy drawing the same.
let lastHud = 0;
let lastBucket = performance.now();
let lastRender = 0;
let framed = false;
function frame() {
	requestAnimationFrame(frame);
	const now = performance.now();
	let fresh = false;
	for (const av of avatars.values())
		fresh = fresh || (av.rec && av.rec.seq !== av.drawnSeq);
	if (renderer && (fresh || dirty || now - lastRender >= 250)) {
		dirty = false;
		lastRender = now;
		const tot = { bones: 0, sensors: 0, stale: 0, grey: 0, off: 0, meshes: 0, bodies: 0, mismatch: 0 };
		for (const av of avatars.values()) {
			if (!av.rec)
				continue;
			const d = draw(av, now);
			av.off = d.off;
			tot.mismatch = Math.max(tot.mismatch, d.mismatch);
			if (av.rec.seq !== av.drawnSeq) {
				av.drawnSeq = av.rec.seq;
				av.drawn.push(now); // a new frame of this avatar on the picture
			}
			tot.bones += d.bones;
			tot.sensors += d.sensors;
			tot.stale += d.stale ? 1 : 0;
			tot.grey += d.grey;
			tot.off += d.off;
			tot.meshes += d.meshes;
			tot.bodies += d.body ? 1 : 0;
		}
		if (following)
			follow();
		else if (autoFrame && avatars.size) {
			frameAll(now, !framed);
			framed = true;
		}
		renderer.render(scene, camera);
		stats.renders++;
		stats.bonesDrawn = tot.bones;
		stats.sensorsDrawn = tot.sensors;
		stats.staleAvatars = tot.stale;
		stats.greySensors = tot.grey;
		stats.offSensors = tot.off;
		stats.meshes = tot.meshes;
		stats.bodies = tot.bodies;
		stats.boneMismatch = tot.mismatch;
	} else if (!renderer) {
		stats.staleAvatars = [...avatars.values()].filter((av) => av.rec &&
			(now - av.rx > STALE_MS || (av.rec.flags & F_STALE) !== 0)).length;
	}
	const tick = now - lastBucket >= BUCKET_MS;
	if (tick)
		lastBucket = now;
	if (tick || now - lastHud > 250) {
		lastHud = now;
		stats.list = [];
		for (const av of [...avatars.values()]) {
			if (!av.rec)
				continue;
			// connected, and no frame of it for a minute: the daemon no longer has it (a reload)
			if (stats.connected && now - av.rx > HISTORY_MS) {
				forget(av);
				continue;
			}
			const st = windowStats(av, now);
			if (tick)
				bucketTick(av, now, st);
			const noFrames = now - av.rx > STALE_MS;
			const grey = noFrames || (av.rec.flags & F_STALE) !== 0;
			updateCard(av, now, st, grey);
			const seen = av.buckets.filter((b) => b.n);
			stats.list.push({ id: av.id, name: av.name, site: av.site, siteStats: av.siteStats, grey, noFrames,
				sensors: av.rec.sensors.map((x) => STATE_NAMES[x.state]), rate: st.rate, outRate: st.outRate,
				received: st.received, shown: st.shown, loss: st.loss, latency: av.latency, off: av.off || 0,
				columns: av.buckets.length, strip: seen.length ? seen[seen.length - 1].states : null });
		}
		$('stats').textContent = JSON.stringify(stats);
	}
}
requestAnimationFrame(frame);
