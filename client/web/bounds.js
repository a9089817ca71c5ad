/*
 * Where a scene is: conservative axis-aligned boxes of primitives and of
 * whole scenes, computed from the page's mirror of the scene (the trees of
 * protocol.js's parseScene), and the camera that frames such a box. Pure
 * functions with no DOM: the page's highlight, its zoom-to-fit and
 * tests/web/bounds.test.mjs use them alike.
 *
 * Conservative means every point of the surface the daemon renders lies
 * inside the box, as far as each primitive's field is a distance outside
 * its own bound (the daemon's culling assumes the same; docs/primitives.md
 * "local bound"). The boxes are not tight: a rotated primitive gets the box
 * of its rotated local box, a smooth union grows by the most its blend can
 * lower the field, and domain nodes (twist, bend, mirror) take whole
 * cylinders or mirrored spans. docs/web.md, "Zoom to fit", says how loose.
 */
import { layout } from './prims.js';

/* bc_camera_default(): the camera of a scene that has none. */
export const DEFAULT_CAMERA = Object.freeze({ eye: [0, 0, 6],
	target: [0, 0, 0], up: [0, 1, 0], fov_y_deg: 45 });

/* The least half size a box gets, so that a point still frames. */
const MIN_HALF = 1e-3;
/* Zoom-to-fit keeps the scene's box inside the view shrunk by this. */
export const FIT_MARGIN = 1.08;
/* Eyes stay within the protocol's coordinate limit (PROTOCOL.md 7.13). */
const MAX_ABS = 1e6;

const sym = (x, y, z) => [[-x, -y, -z], [x, y, z]];

/* The box of the segment a-b grown by r (capsule-like kinds). */
function segment(p, r) {
	const a = p.slice(0, 3), b = p.slice(3, 6);
	return [[0, 1, 2].map((i) => Math.min(a[i], b[i]) - r),
		[0, 1, 2].map((i) => Math.max(a[i], b[i]) + r)];
}

/* A primitive's box [lo, hi] in its local frame, from its kind and
 * parameters (docs/primitives.md: cylinders, cones and revolved profiles
 * stand on the local y axis, extrusions run along z). A kind this page
 * does not know, or parameters that do not match its layout, get a cube
 * of the sum of the parameters' magnitudes: no shape of the table reaches
 * further than that from its origin. */
export function localBox(kind, p) {
	const lay = layout(kind);
	const want = lay ? lay.reduce((a, d) => a + d.count, 0) : -1;
	if (p.length !== want) {
		const m = Math.max(0.05, p.reduce((a, v) => a + Math.abs(v), 0));
		return sym(m, m, m);
	}
	const deg = Math.PI / 180;
	switch (kind) {
	case 1: /* sphere */
	case 10: /* octahedron: vertices at size on the axes */
	case 14: /* solid angle: inside the ball of its radius */
		return sym(p[0], p[0], p[0]);
	case 2: /* box: round stays inside half_extents */
	case 8: /* ellipsoid */
	case 11: /* box frame */
		return sym(p[0], p[1], p[2]);
	case 3: /* capsule */
	case 21: /* capped cylinder: inside the capsule of its radius */
	case 24: /* vesica segment: widest w half way */
		return segment(p, p[6]);
	case 4: /* cylinder */
		return sym(p[0], p[1], p[0]);
	case 5: /* torus */
		return sym(p[0] + p[1], p[1], p[0] + p[1]);
	case 6: { /* cone */
		const r = Math.max(p[1], p[2]);
		return sym(r, p[0], r);
	}
	case 7: /* round cone */
	case 22: /* capped cone */
		return segment(p, Math.max(p[6], p[7]));
	case 9: /* hex prism: corners at 2r / sqrt 3 */
		return sym(2 * p[0] / Math.sqrt(3), p[0], p[1]);
	case 12: { /* capped torus: the arc about +z within angle of it */
		const [R, r, a] = [p[0], p[1], p[2] * deg];
		const x = (a >= Math.PI / 2 ? R : R * Math.sin(a)) + r;
		return [[-x, -r, R * Math.cos(a) - r], [x, r, R + r]];
	}
	case 13: /* link */
		return sym(p[1] + p[2], p[0] + p[1] + p[2], p[2]);
	case 15: /* pyramid: base on y = 0, apex at height */
		return [[-p[0], 0, -p[0]], [p[0], p[1], p[0]]];
	case 16: { /* tri prism: apex (0, 2r), base on y = -r */
		const r = p[0];
		return [[-Math.sqrt(3) * r, -r, -p[1]], [Math.sqrt(3) * r, 2 * r,
			p[1]]];
	}
	case 17: /* cut sphere: below y = cut_height */
		return [[-p[0], -p[0], -p[0]], [p[0], Math.min(p[1], p[0]), p[0]]];
	case 18: { /* cut hollow sphere: a bowl below cut_height */
		const w = p[0] + p[2];
		return [[-w, -w, -w], [w, Math.min(p[1], p[0]) + p[2], w]];
	}
	case 19: /* death star: the ball ra less another */
		return sym(p[0], p[0], p[0]);
	case 20: /* rounded cylinder: radius, round, half_height */
		return sym(p[0], p[2], p[0]);
	case 23: /* rhombus: half diagonals grown by round */
		return sym(p[0] + p[3], p[2], p[1] + p[3]);
	case 25: /* extrude circle */
		return sym(p[0], p[0], p[1]);
	case 26: /* extrude rect */
		return sym(p[0], p[1], p[2]);
	case 27: /* extrude polygon: inside its circumcircle */
		return sym(p[0], p[0], p[2]);
	case 28: /* extrude star: tips at radius */
		return sym(p[0], p[0], p[3]);
	case 29: { /* revolve circle: radius, offset */
		const R = p[1] + p[0];
		return sym(R, p[0], R);
	}
	case 30: { /* revolve rect: half_width, half_height, offset */
		const R = p[2] + p[0];
		return sym(R, p[1], R);
	}
	case 31: { /* revolve polygon: radius, sides, offset */
		const R = p[2] + p[0];
		return sym(R, p[0], R);
	}
	case 32: { /* revolve star: radius, points, inner_ratio, offset */
		const R = p[3] + p[0];
		return sym(R, p[0], R);
	}
	default: {
		const m = Math.max(0.05, p.reduce((a, v) => a + Math.abs(v), 0));
		return sym(m, m, m);
	}
	}
}

/* Rotates v by the unit quaternion q = (x, y, z, w). */
export function quatRotate(q, v) {
	const [x, y, z, w] = q;
	const t = [2 * (y * v[2] - z * v[1]), 2 * (z * v[0] - x * v[2]),
		2 * (x * v[1] - y * v[0])];
	return [v[0] + w * t[0] + (y * t[2] - z * t[1]),
		v[1] + w * t[1] + (z * t[0] - x * t[2]),
		v[2] + w * t[2] + (x * t[1] - y * t[0])];
}

/* The 8 corners of [lo, hi]; corner i takes hi on axis k when bit k of i
 * is set. */
export function corners([lo, hi]) {
	const out = [];
	for (let i = 0; i < 8; i++) {
		out.push([i & 1 ? hi[0] : lo[0], i & 2 ? hi[1] : lo[1],
			i & 4 ? hi[2] : lo[2]]);
	}
	return out;
}

/* The box of some points. */
function boxOf(points) {
	const lo = [Infinity, Infinity, Infinity];
	const hi = [-Infinity, -Infinity, -Infinity];
	for (const p of points) {
		for (let k = 0; k < 3; k++) {
			lo[k] = Math.min(lo[k], p[k]);
			hi[k] = Math.max(hi[k], p[k]);
		}
	}
	return [lo, hi];
}

/* A primitive node's box in its parent's frame: its local box turned by
 * its rotation and moved by its translation. */
export function primBox(n) {
	return boxOf(corners(localBox(n.kind, n.params)).map((c) => {
		const r = quatRotate(n.rotate, c);
		return [r[0] + n.translate[0], r[1] + n.translate[1],
			r[2] + n.translate[2]];
	}));
}

const grow = ([lo, hi], d) => [lo.map((v) => v - d), hi.map((v) => v + d)];

function unite(a, b) {
	if (!a || !b) {
		return a ?? b;
	}
	return [a[0].map((v, k) => Math.min(v, b[0][k])),
		a[1].map((v, k) => Math.max(v, b[1][k]))];
}

function meet(a, b) {
	if (!a || !b) {
		return null;
	}
	const lo = a[0].map((v, k) => Math.max(v, b[0][k]));
	const hi = a[1].map((v, k) => Math.min(v, b[1][k]));
	return lo.every((v, k) => v <= hi[k]) ? [lo, hi] : null;
}

/* Where a unary or domain node (kinds 7..14, docs/scene-format.md) puts
 * its child's box (in the child's frame): every point it maps into the box
 * is in the result. */
function unaryBox(n, b) {
	if (!b) {
		return null;
	}
	const u = n.params;
	const [lo, hi] = b;
	switch (n.kind) {
	case 7: /* offset: f - amount */
		return grow(b, Math.max(u[0], 0));
	case 8: /* onion: |f| - thickness */
		return grow(b, Math.max(u[0], 0));
	case 9: /* elongate: each side moves out by h */
		return [lo.map((v, k) => v - Math.abs(u[k])),
			hi.map((v, k) => v + Math.abs(u[k]))];
	case 10: /* twist about y: keeps y and the distance to the axis */
	case 11: { /* bend about z: keeps z and the distance to it */
		const [a, c] = n.kind === 10 ? [0, 2] : [0, 1];
		const R = Math.max(...corners(b).map((p) => Math.hypot(p[a],
			p[c])));
		const out = [lo.slice(), hi.slice()];
		for (const k of [a, c]) {
			out[0][k] = -R;
			out[1][k] = R;
		}
		return out;
	}
	case 12: { /* mirror: |p| on the axes of the mask */
		const out = [lo.slice(), hi.slice()];
		for (let k = 0; k < 3; k++) {
			if (Math.round(u[0]) & (1 << k)) {
				const m = Math.max(Math.abs(lo[k]), Math.abs(hi[k]));
				out[0][k] = -m;
				out[1][k] = m;
			}
		}
		return out;
	}
	case 13: /* repeat: count copies spacing apart, centred */
		return [lo.map((v, k) => v - Math.abs(u[k]) * (u[k + 3] - 1) / 2),
			hi.map((v, k) => v + Math.abs(u[k]) * (u[k + 3] - 1) / 2)];
	case 14: /* scale: factor * f(p / factor) */
		return [lo.map((v) => v * u[0]), hi.map((v) => v * u[0])];
	default:
		return b;
	}
}

/* An operator's box from its children's (sharp and smooth alike). */
function opBox(n, kids) {
	switch (n.kind) {
	case 1: /* union */
		return kids.reduce(unite, null);
	case 4: { /* smooth union: the blend lowers the field by <= blend/6 */
		const b = kids.reduce(unite, null);
		return b ? grow(b, Math.max(n.blend, 0) / 6) : null;
	}
	case 2: /* intersection, sharp or smooth: inside every child */
	case 5:
		return kids.reduce((a, k) => meet(a, k));
	case 3: /* difference, sharp or smooth: inside the first child */
	case 6:
		return kids[0];
	default:
		return kids.reduce(unite, null);
	}
}

/* The box [lo, hi] of a whole tree (a parseScene root) in world space, or
 * null when it has no surface anywhere (no root, an empty intersection).
 * Walks without recursion: trees may nest 2^20 deep. */
export function treeBox(root) {
	if (!root) {
		return null;
	}
	const done = new Map(); /* node -> box, until its parent takes it */
	const todo = [[root, false]];
	while (todo.length) {
		const [n, expanded] = todo.pop();
		if (!n.isOp) {
			done.set(n, primBox(n));
			continue;
		}
		if (!expanded) {
			todo.push([n, true]);
			for (const c of n.children) {
				todo.push([c, false]);
			}
			continue;
		}
		const kids = n.children.map((c) => {
			const b = done.get(c);
			done.delete(c);
			return b ?? null;
		});
		done.set(n, n.unary ? unaryBox(n, kids[0]) : opBox(n, kids));
	}
	return done.get(root) ?? null;
}

const sub = (a, b) => [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
const dot = (a, b) => a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
const cross = (a, b) => [a[1] * b[2] - a[2] * b[1],
	a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
const unit = (a) => {
	const l = Math.hypot(...a);
	return l > 0 ? a.map((v) => v / l) : null;
};

/* The camera that shows box [lo, hi] whole in a view of aspect w / h:
 * it keeps cam's direction, up and field of view, looks at the box's
 * centre and stands back just far enough for every corner of the box to
 * lie inside the view shrunk by FIT_MARGIN (the page's conventions:
 * forward = target - eye, right = forward x up). Returns { eye, target,
 * up, fov_y_deg }. */
export function fitCamera(cam, box, aspect) {
	const [lo, hi] = box;
	const c = lo.map((v, k) => (v + hi[k]) / 2);
	const f = unit(sub(cam.target, cam.eye)) ?? [0, 0, -1];
	const r = unit(cross(f, cam.up)) ?? unit(cross(f, [0, 0, 1]));
	const u = cross(r, f);
	const ty = Math.tan(cam.fov_y_deg * Math.PI / 360) / FIT_MARGIN;
	const tx = ty * Math.max(aspect, 1e-3);
	/* A corner at q from the centre is seen at depth d + q.f: it is in
	 * view when |q.r| <= (d + q.f) tx and |q.u| <= (d + q.f) ty. */
	let d = MIN_HALF;
	for (const p of corners(box)) {
		const q = sub(p, c);
		const z = dot(q, f);
		d = Math.max(d, Math.abs(dot(q, r)) / tx - z,
			Math.abs(dot(q, u)) / ty - z, MIN_HALF - z);
	}
	d = Math.min(d, MAX_ABS);
	const clamp = (v) => Math.max(-MAX_ABS, Math.min(MAX_ABS, v));
	return { eye: c.map((v, k) => clamp(v - f[k] * d)), target: c,
		up: cam.up.slice(), fov_y_deg: cam.fov_y_deg };
}
