/*
 * The primitive and operator kinds as the page names and edits them: each
 * primitive kind's parameters in the order of docs/primitives.md (and of
 * blobtree/prim.c, which tests/web/prims.test.mjs checks this table
 * against), with their component counts. Field number 16 + k of an EDIT
 * sets parameter k, and in the scene encoding its floats follow those of
 * the parameters before it.
 */

/* kind -> [name, [[parameter, component count, rule], ...]]. Rule 'pos' is
 * > 0, 'nonneg' >= 0, 'deg' an angle in degrees, 'free' any coordinate. */
export const PRIMS = Object.freeze({
	1: ['sphere', [['radius', 1, 'pos']]],
	2: ['box', [['half_extents', 3, 'pos'], ['round', 1, 'nonneg']]],
	3: ['capsule', [['a', 3, 'free'], ['b', 3, 'free'], ['radius', 1, 'pos']]],
	4: ['cylinder', [['radius', 1, 'pos'], ['half_height', 1, 'pos']]],
	5: ['torus', [['major', 1, 'pos'], ['minor', 1, 'pos']]],
	6: ['cone', [['half_height', 1, 'pos'], ['radius_bottom', 1, 'nonneg'],
		['radius_top', 1, 'nonneg']]],
	7: ['round_cone', [['a', 3, 'free'], ['b', 3, 'free'],
		['radius_a', 1, 'nonneg'], ['radius_b', 1, 'nonneg']]],
	8: ['ellipsoid', [['radii', 3, 'pos']]],
	9: ['hex_prism', [['radius', 1, 'pos'], ['half_depth', 1, 'pos']]],
	10: ['octahedron', [['size', 1, 'pos']]],
	11: ['box_frame', [['half_extents', 3, 'pos'], ['thickness', 1, 'pos']]],
	12: ['capped_torus', [['major', 1, 'pos'], ['minor', 1, 'pos'],
		['angle_deg', 1, 'deg']]],
	13: ['link', [['half_length', 1, 'nonneg'], ['major', 1, 'pos'],
		['minor', 1, 'pos']]],
	14: ['solid_angle', [['radius', 1, 'pos'], ['angle_deg', 1, 'deg']]],
	15: ['pyramid', [['half_base', 1, 'pos'], ['height', 1, 'pos']]],
	16: ['tri_prism', [['radius', 1, 'pos'], ['half_depth', 1, 'pos']]],
	17: ['cut_sphere', [['radius', 1, 'pos'], ['cut_height', 1, 'free']]],
	18: ['cut_hollow_sphere', [['radius', 1, 'pos'],
		['cut_height', 1, 'free'], ['thickness', 1, 'pos']]],
	19: ['death_star', [['ra', 1, 'pos'], ['rb', 1, 'pos'], ['d', 1, 'pos']]],
	20: ['rounded_cylinder', [['radius', 1, 'pos'], ['round', 1, 'nonneg'],
		['half_height', 1, 'pos']]],
	21: ['capped_cylinder', [['a', 3, 'free'], ['b', 3, 'free'],
		['radius', 1, 'pos']]],
	22: ['capped_cone', [['a', 3, 'free'], ['b', 3, 'free'],
		['ra', 1, 'nonneg'], ['rb', 1, 'nonneg']]],
	23: ['rhombus', [['la', 1, 'pos'], ['lb', 1, 'pos'],
		['half_height', 1, 'pos'], ['round', 1, 'nonneg']]],
	24: ['vesica_segment', [['a', 3, 'free'], ['b', 3, 'free'],
		['w', 1, 'pos']]],
	25: ['extrude_circle', [['radius', 1, 'pos'], ['half_depth', 1, 'pos']]],
	26: ['extrude_rect', [['half_width', 1, 'pos'], ['half_height', 1, 'pos'],
		['half_depth', 1, 'pos']]],
	27: ['extrude_polygon', [['radius', 1, 'pos'], ['sides', 1, 'pos'],
		['half_depth', 1, 'pos']]],
	28: ['extrude_star', [['radius', 1, 'pos'], ['points', 1, 'pos'],
		['inner_ratio', 1, 'pos'], ['half_depth', 1, 'pos']]],
	29: ['revolve_circle', [['radius', 1, 'pos'], ['offset', 1, 'nonneg']]],
	30: ['revolve_rect', [['half_width', 1, 'pos'], ['half_height', 1, 'pos'],
		['offset', 1, 'nonneg']]],
	31: ['revolve_polygon', [['radius', 1, 'pos'], ['sides', 1, 'pos'],
		['offset', 1, 'nonneg']]],
	32: ['revolve_star', [['radius', 1, 'pos'], ['points', 1, 'pos'],
		['inner_ratio', 1, 'pos'], ['offset', 1, 'nonneg']]],
});

/* Operator kinds 1..6 and unary node kinds 7..14 (the OP_KIND field's
 * values). */
export const OPS = Object.freeze(['', 'union', 'intersection', 'difference',
	'smooth_union', 'smooth_intersection', 'smooth_difference', 'offset',
	'onion', 'elongate', 'twist', 'bend', 'mirror', 'repeat', 'scale']);

/* Unary and domain nodes (docs/scene-format.md): kind -> [name,
 * [[parameter, component count, rule], ...]], field 16 + k setting
 * parameter k as for primitives (blobtree's bc_unary_info and edit/fields.c).
 * Rules as PRIMS', plus 'mask' (mirror's axes, an integer 1..7: x 1, y 2,
 * z 4) and 'count' (repeat's copies per axis, integers >= 1). */
export const UNARY = Object.freeze({
	7: ['offset', [['amount', 1, 'free']]],
	8: ['onion', [['thickness', 1, 'nonneg']]],
	9: ['elongate', [['half_extents', 3, 'nonneg']]],
	10: ['twist', [['rate', 1, 'free']]],
	11: ['bend', [['rate', 1, 'free']]],
	12: ['mirror', [['axes', 1, 'mask']]],
	13: ['repeat', [['spacing', 3, 'nonneg'], ['count', 3, 'count']]],
	14: ['scale', [['factor', 1, 'pos']]],
});

/* [{ name, offset, count, rule }] for a unary kind, or null. */
export function unaryLayout(kind) {
	const u = UNARY[kind];
	if (!u) {
		return null;
	}
	let offset = 0;
	return u[1].map(([name, count, rule]) => {
		const d = { name, offset, count, rule };
		offset += count;
		return d;
	});
}

/* A slider's [lo, hi] for a unary parameter now at v, and the value a
 * slider position v sends (whole numbers for masks and counts). */
export function unaryRange(rule, v) {
	switch (rule) {
	case 'mask':
		return [1, 7];
	case 'count':
		return [1, Math.max(8, 2 * v)];
	case 'pos':
		return [0.01, Math.max(2, 3 * v)];
	case 'nonneg':
		return [0, Math.max(1, 3 * v)];
	default:
		return [v - 2 * Math.abs(v) - 1, v + 2 * Math.abs(v) + 1];
	}
}

export function unaryValue(rule, v) {
	return rule === 'mask' || rule === 'count' ? Math.round(v) : v;
}

/* [{ name, offset, count, rule }] for a primitive kind, or null if it is
 * unknown. */
export function layout(kind) {
	const p = PRIMS[kind];
	if (!p) {
		return null;
	}
	let offset = 0;
	return p[1].map(([name, count, rule]) => {
		const d = { name, offset, count, rule };
		offset += count;
		return d;
	});
}
