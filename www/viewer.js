// SPDX-License-Identifier: MIT
// The avatargw viewer (docs/VIEWER.md): the JSON frames of the daemon's websocket output drawn
// with three.js from Debian's libjs-three, served by the daemon under /three/. One stick figure
// per avatar from its segment poses, the raw tracker poses as small axes beside it, a line from
// each sensor to where the IK put that body part, grey when stale; per-avatar rate, loss and
// latency in the corner. What it drew is in window.avatargwStats (the tests read it).
import * as THREE from '/three/build/three.module.js';
import { OrbitControls } from '/three/examples/jsm/controls/OrbitControls.js';

const STALE_MS = 500;          // no frame for this long: the avatar turns grey
const WINDOW_MS = 2000;        // rates and loss over the last two seconds
const F_STALE = 1;             // FRAME flag: a sensor is stale or missing
// segments: 0 chest, 1 head, 2-5 right shoulder, elbow, wrist, hand, 6-9 the same on the left
const BONES = [[0, 1], [0, 2], [2, 3], [3, 4], [4, 5], [0, 6], [6, 7], [7, 8], [8, 9]];
const SENSOR_SEGMENT = [1, 9, 5]; // head, left-hand and right-hand sensors, and what follows them
const SENSOR_NAMES = ['head', 'left hand', 'right hand'];
const PALETTE = [0x4fc3f7, 0xffb74d, 0x81c784, 0xf06292, 0xba68c8, 0xfff176, 0x4db6ac, 0xa1887f];
const GREY = 0x6b6f76;
const TORSO = 0.45;            // drawn below the chest, for a body-like figure (not tracked)

const stats = {
	frames: 0,        // messages received
	avatars: 0,       // avatars drawn
	bonesDrawn: 0,    // bone lines drawn in the last picture
	sensorsDrawn: 0,  // sensor axes drawn in the last picture
	staleAvatars: 0,  // avatars drawn grey in the last picture
	greySensors: 0,   // sensor axes drawn grey (stale or missing)
	renders: 0,       // pictures drawn
	connected: false,
	webgl: false,
	lastSeq: {},      // avatar id -> the seq of its newest frame
};
window.avatargwStats = stats;

// ---- the scene ------------------------------------------------------------------------------
const view = document.getElementById('view');
let renderer = null;
try {
	renderer = new THREE.WebGLRenderer({ antialias: true });
	renderer.setPixelRatio(window.devicePixelRatio);
	renderer.setSize(window.innerWidth, window.innerHeight);
	view.appendChild(renderer.domElement);
	stats.webgl = true;
} catch (e) {
	document.getElementById('status').textContent = 'no WebGL in this browser: ' + e.message;
}
const scene = new THREE.Scene();
scene.background = new THREE.Color(0x15181c);
const camera = new THREE.PerspectiveCamera(50, window.innerWidth / window.innerHeight, 0.01, 200);
camera.position.set(2.2, 1.9, 2.6);
// avatargw's world is z up; three.js is y up: everything tracked lives in this turned group
const world = new THREE.Group();
world.rotation.x = -Math.PI / 2;
scene.add(world);
const grid = new THREE.GridHelper(10, 20, 0x556070, 0x2c323a); // a 10 m floor, 0.5 m squares
scene.add(grid);
world.add(new THREE.AxesHelper(0.5)); // x red, y green, z blue: avatargw's own axes
let controls = null;
if (renderer) {
	controls = new OrbitControls(camera, renderer.domElement);
	controls.target.set(0, 1.1, 0);
	controls.update();
}
window.addEventListener('resize', () => {
	camera.aspect = window.innerWidth / window.innerHeight;
	camera.updateProjectionMatrix();
	if (renderer)
		renderer.setSize(window.innerWidth, window.innerHeight);
});

function finite(a) {
	return Array.isArray(a) && a.every((v) => v !== null && Number.isFinite(v));
}

function label(text) {
	const c = document.createElement('canvas');
	c.width = 256;
	c.height = 64;
	const g = c.getContext('2d');
	g.font = '28px sans-serif';
	g.fillStyle = '#dde';
	g.textAlign = 'center';
	g.fillText(text, 128, 40);
	const s = new THREE.Sprite(new THREE.SpriteMaterial({ map: new THREE.CanvasTexture(c), depthTest: false }));
	s.scale.set(0.4, 0.1, 1);
	return s;
}

// ---- avatars --------------------------------------------------------------------------------
const avatars = new Map(); // id -> drawn avatar

function makeAvatar(id, name) {
	const color = new THREE.Color(PALETTE[avatars.size % PALETTE.length]);
	const group = new THREE.Group();
	const boneGeo = new THREE.BufferGeometry();
	boneGeo.setAttribute('position', new THREE.Float32BufferAttribute(new Float32Array((BONES.length + 1) * 6), 3));
	const bones = new THREE.LineSegments(boneGeo, new THREE.LineBasicMaterial({ color }));
	group.add(bones);
	const jointGeo = new THREE.BufferGeometry();
	jointGeo.setAttribute('position', new THREE.Float32BufferAttribute(new Float32Array(10 * 3), 3));
	const joints = new THREE.Points(jointGeo, new THREE.PointsMaterial({ color, size: 0.04 }));
	group.add(joints);
	const errGeo = new THREE.BufferGeometry();
	errGeo.setAttribute('position', new THREE.Float32BufferAttribute(new Float32Array(3 * 6), 3));
	const err = new THREE.LineSegments(errGeo, new THREE.LineBasicMaterial({ color: 0xff5252 }));
	group.add(err);
	const sensors = [];
	for (let s = 0; s < 3; s++) {
		const a = new THREE.AxesHelper(s === 0 ? 0.12 : 0.08);
		a.visible = false;
		group.add(a);
		sensors.push(a);
	}
	const tag = label(name || ('avatar ' + id));
	group.add(tag);
	world.add(group);
	const av = { id, name, color, group, bones, joints, err, sensors, tag, rec: null, rx: 0, hist: [],
		     framed: false };
	avatars.set(id, av);
	return av;
}

function setPoint(attr, i, p) {
	attr.setXYZ(i, p[0], p[1], p[2]);
}

function draw(av, now) {
	const rec = av.rec;
	const stale = now - av.rx > STALE_MS || (rec.flags & F_STALE) !== 0;
	const seg = rec.segments;
	const bp = av.bones.geometry.attributes.position;
	let drawn = 0;

	av.bones.material.color.set(stale ? GREY : av.color);
	av.joints.material.color.set(stale ? GREY : av.color);
	BONES.forEach(([a, b], i) => {
		// an unknown segment (a missing head) is left out: both ends on one point draw nothing
		if (finite(seg[a]) && finite(seg[b])) {
			setPoint(bp, 2 * i, seg[a]);
			setPoint(bp, 2 * i + 1, seg[b]);
			drawn++;
		} else {
			bp.setXYZ(2 * i, 0, 0, 0);
			bp.setXYZ(2 * i + 1, 0, 0, 0);
		}
	});
	// the torso, down from the chest
	if (finite(seg[0])) {
		setPoint(bp, 2 * BONES.length, seg[0]);
		bp.setXYZ(2 * BONES.length + 1, seg[0][0], seg[0][1], seg[0][2] - TORSO);
	}
	bp.needsUpdate = true;
	const jp = av.joints.geometry.attributes.position;
	seg.forEach((p, i) => (finite(p) ? setPoint(jp, i, p) : jp.setXYZ(i, 0, 0, -100)));
	jp.needsUpdate = true;
	// the raw sensors, and a line from each to the body part that follows it
	const ep = av.err.geometry.attributes.position;
	let sensors = 0;
	let grey = 0;
	rec.sensors.forEach((s, i) => {
		const a = av.sensors[i];
		const p = s.pose;
		a.visible = finite(p);
		if (!a.visible) {
			ep.setXYZ(2 * i, 0, 0, 0);
			ep.setXYZ(2 * i + 1, 0, 0, 0);
			return;
		}
		a.position.set(p[0], p[1], p[2]);
		a.quaternion.set(p[4], p[5], p[6], p[3]); // the wire's w, x, y, z -> three's x, y, z, w
		const dim = stale || s.state !== 0;
		const vc = dim ? THREE.NoColors : THREE.VertexColors;
		if (a.material.vertexColors !== vc) {
			a.material.vertexColors = vc;
			a.material.color.set(dim ? GREY : 0xffffff);
			a.material.needsUpdate = true;
		}
		grey += dim ? 1 : 0;
		setPoint(ep, 2 * i, p);
		const t = seg[SENSOR_SEGMENT[i]];
		setPoint(ep, 2 * i + 1, finite(t) ? t : p);
		sensors++;
	});
	ep.needsUpdate = true;
	const head = finite(seg[1]) ? seg[1] : seg[0];
	if (finite(head))
		av.tag.position.set(head[0], head[1], head[2] + 0.22);
	av.tag.material.color.set(stale ? GREY : 0xffffff);
	return { bones: drawn, sensors, stale, grey };
}

// ---- the numbers ----------------------------------------------------------------------------
function fmt(v, digits) {
	return v === null || !Number.isFinite(v) ? '–' : v.toFixed(digits);
}

function avatarStats(av, now) {
	// the records of the last WINDOW_MS: [arrival, seq, k, the daemon's time of sending]
	av.hist = av.hist.filter((h) => now - h[0] <= WINDOW_MS);
	const h = av.hist;
	const out = { rate: null, shown: null, loss: null };
	if (h.length >= 2) {
		const last = h[h.length - 1];
		const dt = (last[0] - h[0][0]) / 1000;
		const dsend = (last[3] - h[0][3]) / 1000; // the daemon's clock: arrival bursts do not count
		const dseq = (last[1] - h[0][1]) >>> 0;
		const dk = last[2] - h[0][2];
		if (dsend > 0)
			out.rate = dseq / dsend;
		if (dt > 0)
			out.shown = (h.length - 1) / dt;
		if (dk > 0)
			out.loss = 100 * (dk - (h.length - 1)) / dk;
	}
	return out;
}

function hud(now) {
	const rows = [];
	for (const av of avatars.values()) {
		const r = av.rec;
		const st = avatarStats(av, now);
		const stale = now - av.rx > STALE_MS || (r.flags & F_STALE) !== 0;
		const states = r.sensors.map((s, i) => (s.state === 0 ? '' : SENSOR_NAMES[i] + (s.state === 1 ? ' stale' : ' missing')))
			.filter((x) => x);
		const latency = Date.now() - r.t;
		const ikErr = r.ik_err.map((e) => fmt(e === null ? null : e * 1000, 1)).join(' / ');
		rows.push('<tr' + (stale ? ' class="stale"' : '') + '><td><span class="swatch" style="background:#' +
			  (stale ? GREY : av.color.getHex()).toString(16).padStart(6, '0') + '"></span>' +
			  (r.name || 'avatar') + ' <small>#' + r.id + '</small></td><td>' +
			  (now - av.rx > STALE_MS ? 'no frames' : states.length ? states.join(', ') : 'ok') + '</td><td>' +
			  fmt(st.rate, 0) + '</td><td>' + fmt(st.shown, 0) + '</td><td>' + fmt(st.loss, 1) + '</td><td>' +
			  fmt(latency, 1) + '</td><td>' + fmt(r.srv_ms, 1) + '</td><td>' + ikErr + '</td></tr>');
	}
	document.getElementById('avatars').innerHTML = rows.join('');
}

// ---- the connection -------------------------------------------------------------------------
function onFrames(msg) {
	const now = performance.now();
	stats.frames++;
	for (const rec of msg.avatars) {
		let av = avatars.get(rec.id);
		if (!av)
			av = makeAvatar(rec.id, rec.name);
		else if (rec.name && rec.name !== av.name) {
			av.group.remove(av.tag);
			av.tag = label(rec.name);
			av.group.add(av.tag);
			av.name = rec.name;
		}
		av.rec = rec;
		av.rx = now;
		av.hist.push([now, rec.seq, rec.k, msg.t]);
		stats.lastSeq[rec.id] = rec.seq;
		// the first frame of the first avatar: look at it, from in front (it faces avatargw's +y)
		if (!av.framed && avatars.size === 1 && finite(rec.segments[0]) && controls) {
			const c = rec.segments[0];
			controls.target.set(c[0], c[2] - 0.25, -c[1]);
			camera.position.set(c[0] + 0.9, c[2] + 0.1, -c[1] - 1.9);
			controls.update();
		}
		av.framed = true;
	}
	stats.avatars = avatars.size;
}

function connect() {
	const status = document.getElementById('status');
	const ws = new WebSocket((location.protocol === 'https:' ? 'wss://' : 'ws://') + location.host + '/', 'avatargw-json');
	ws.onopen = () => {
		stats.connected = true;
		status.textContent = 'connected to ' + location.host;
	};
	ws.onmessage = (ev) => {
		const msg = JSON.parse(ev.data);
		if (msg.type === 'frames')
			onFrames(msg);
	};
	ws.onclose = () => {
		stats.connected = false;
		status.textContent = 'disconnected: trying again…';
		setTimeout(connect, 1000);
	};
}
connect();

// ---- the picture ----------------------------------------------------------------------------
let lastHud = 0;
function frame() {
	requestAnimationFrame(frame);
	const now = performance.now();
	let bones = 0;
	let sensors = 0;
	let stale = 0;
	let grey = 0;
	for (const av of avatars.values()) {
		const d = draw(av, now);
		bones += d.bones;
		sensors += d.sensors;
		stale += d.stale ? 1 : 0;
		grey += d.grey;
	}
	if (renderer) {
		controls.update();
		renderer.render(scene, camera);
		stats.renders++;
		stats.bonesDrawn = bones;
		stats.sensorsDrawn = sensors;
		stats.staleAvatars = stale;
		stats.greySensors = grey;
	}
	if (now - lastHud > 250) {
		lastHud = now;
		if (avatars.size)
			hud(now);
		document.getElementById('stats').textContent = JSON.stringify(stats);
	}
}
requestAnimationFrame(frame);
