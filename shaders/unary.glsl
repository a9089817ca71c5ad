// Unary and domain nodes (docs/scene-format.md, "Unary and domain nodes"),
// as blobtree/eval.c computes them: domain maps on the point a primitive
// sees, value maps on the value of the slot they wrap. Needs common.glsl.
//
// The host appends two tables to the Topo buffer when the tree has unary
// nodes (u_counts.w = the slot count, 0 without them): per slot
// (innermost wrapper, innermost domain node around it, value-changing
// wrappers among its ancestors, 0) at b_topo[w + s], and per unary node
// (kind, record offset, next wrapper out, next domain node out) at
// b_topo[2 w + u]. Their records are 2 vec4 in b_param.

#define BC_OP_OFFSET 7u
#define BC_OP_ONION 8u
#define BC_OP_ELONGATE 9u
#define BC_OP_TWIST 10u
#define BC_OP_BEND 11u
#define BC_OP_MIRROR 12u
#define BC_OP_REPEAT 13u
#define BC_OP_SCALE 14u
// blobtree.h's BC_DOMAIN_MAX_CHAIN.
#define BC_DOMAIN_MAX_CHAIN 32u

// Only the program built with BC_UNARY defined (render/gl/program.c) reads
// the tables: trees without unary nodes run a tracer compiled without any
// of this code.
bool bc_has_unary()
{
#ifdef BC_UNARY
	return u_counts.w != 0u;
#else
	return false;
#endif
}

uvec4 bc_slot_unary(uint s)
{
	return b_topo[u_counts.w + s];
}

uvec4 bc_unary_node(uint u)
{
	return b_topo[2u * u_counts.w + u];
}

bool bc_unary_has_value(uint kind)
{
	return kind == BC_OP_OFFSET || kind == BC_OP_ONION ||
	       kind == BC_OP_TWIST || kind == BC_OP_BEND || kind == BC_OP_SCALE;
}

// eval.c's domain_apply: p from the node's input frame to its child's.
vec3 bc_domain_apply(uint kind, vec4 a, vec4 b, vec3 p)
{
	if (kind == BC_OP_ELONGATE) {
		return p - clamp(p, -a.xyz, a.xyz);
	}
	if (kind == BC_OP_TWIST) {
		float t = a.x * p.y, c = cos(t), s = sin(t);
		return vec3(c * p.x + s * p.z, p.y, -s * p.x + c * p.z);
	}
	if (kind == BC_OP_BEND) {
		float t = a.x * p.x, c = cos(t), s = sin(t);
		return vec3(c * p.x + s * p.y, -s * p.x + c * p.y, p.z);
	}
	if (kind == BC_OP_MIRROR) {
		uint m = uint(a.x);
		return vec3((m & 1u) != 0u ? abs(p.x) : p.x,
			    (m & 2u) != 0u ? abs(p.y) : p.y,
			    (m & 4u) != 0u ? abs(p.z) : p.z);
	}
	if (kind == BC_OP_REPEAT) {
		// spacing a.xyz, counts (a.w, b.x, b.y).
		vec3 sp = a.xyz, n = vec3(a.w, b.x, b.y);
		for (int i = 0; i < 3; i++) {
			if (!(n[i] > 1.0)) {
				continue;
			}
			float o = 0.5 * (n[i] - 1.0);
			float id = floor(p[i] / sp[i] + o + 0.5);
			id = min(max(id, 0.0), n[i] - 1.0);
			p[i] -= sp[i] * (id - o);
		}
		return p;
	}
	if (kind == BC_OP_SCALE) {
		return p * a.y;
	}
	return p;
}

// bc_domain_map: p through the domain nodes from d outward, outermost
// first. No local array (llvmpipe indexes those slowly): each turn walks
// from d to the outermost node not yet applied; chains are short.
vec3 bc_domain_map(uint d, vec3 p)
{
	uint done = BC_NONE;
	for (uint turn = 0u; turn < BC_DOMAIN_MAX_CHAIN && d != done; turn++) {
		uint x = d;
		for (uint k = 0u; k < BC_DOMAIN_MAX_CHAIN; k++) {
			uint nx = bc_unary_node(x).w;
			if (nx == done) {
				break;
			}
			x = nx;
		}
		uvec4 u = bc_unary_node(x);
		p = bc_domain_apply(u.x, b_param[u.y], b_param[u.y + 1u], p);
		done = x;
	}
	return p;
}

// linearize.c's bc_unary_own_lip.
float bc_unary_own_lip(uint kind, float rate, float r)
{
	float m = abs(rate) * r;
	return kind == BC_OP_TWIST ? 0.5 * (m + sqrt(m * m + 4.0)) : 1.0 + m;
}

// bc_unary_value: node u's value map of its child's value f at world p.
float bc_unary_value(uint u, float f, vec3 p)
{
	uvec4 n = bc_unary_node(u);
	vec4 a = b_param[n.y];
	if (n.x == BC_OP_OFFSET) {
		return f - a.x;
	}
	if (n.x == BC_OP_ONION) {
		return abs(f) - a.x;
	}
	if (n.x == BC_OP_SCALE) {
		return f * a.x;
	}
	if (n.x == BC_OP_TWIST || n.x == BC_OP_BEND) {
		vec3 q = bc_domain_map(n.w, p);
		float r = n.x == BC_OP_TWIST ? length(q.xz) : length(q.xy);
		if (r > a.y && f > 0.0) {
			return f * bc_unary_own_lip(n.x, a.x, a.y) /
			       bc_unary_own_lip(n.x, a.x, r);
		}
	}
	return f;
}
