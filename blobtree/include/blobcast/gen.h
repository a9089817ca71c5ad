/*
 * Scene generators: the synthetic scenes of the papers' benchmarks (Zanni
 * 2024 Fig. 16 and 18, the thesis' Gears, Many Gears and Many Spheres), a
 * left comb, and random trees for tests. Each builds a bc_tree and a camera
 * that frames it, deterministically from its options: the same options give
 * the same scene, bit for bit, on every machine (our own PRNG, no rand()).
 */
#ifndef BLOBCAST_GEN_H
#define BLOBCAST_GEN_H

#include <stddef.h>
#include <stdint.h>

#include "blobcast/blobtree.h"
#include "blobcast/error.h"

/* Deepest fig16 recursion: level 6 has 1,111,110 primitives, which is as
 * large as the paper's largest synthetic scene (its Fig. 16f). */
#define BC_GEN_MAX_LEVEL 6
/* Most primitives a generator makes: the linearized form of n primitives
 * has 2n - 1 nodes, which must stay within BC_TREE_MAX_NODES. */
#define BC_GEN_MAX_PRIMS ((BC_TREE_MAX_NODES - 1u) / 2u)
/* Most teeth on a gear: beyond this the teeth are thinner than the float
 * precision of their rotation makes worthwhile. */
#define BC_GEN_MAX_TEETH 1000u
/* Deepest nesting of a random scene. Random operators put subtrees on both
 * sides, and each level nested in a right operand costs an evaluation stack
 * entry, so random trees stay within BC_EVAL_STACK (130); the generator
 * also recurses once per level. */
#define BC_GEN_RANDOM_MAX_DEPTH 128u

/* fig18's instance shape. */
enum bc_gen_kind {
	BC_GEN_KIND_DEFAULT = 0, /* boxes */
	BC_GEN_KIND_BOXES,
	BC_GEN_KIND_SPHERES,
	BC_GEN_KIND_LENSES, /* two intersected spheres (the paper's Fig. 18g) */
	BC_GEN_KIND_COUNT
};

enum bc_gen_blend {
	BC_GEN_BLEND_DEFAULT = 0, /* the generator's own choice */
	BC_GEN_BLEND_SHARP,
	BC_GEN_BLEND_SMOOTH,
	BC_GEN_BLEND_COUNT
};

/* Options; zero means the generator's default. An option the generator
 * does not read must be zero (BC_EINVAL otherwise), so that a mistyped
 * command line is caught instead of silently ignored. */
struct bc_gen_opts {
	uint32_t level; /* fig16: recursion level 1..BC_GEN_MAX_LEVEL */
	uint32_t count; /* instances, primitives or gears */
	uint64_t seed;  /* PRNG seed; 0 is a seed like any other */
	enum bc_gen_kind kind;
	enum bc_gen_blend blend;
	uint32_t teeth; /* gears: teeth of the largest gear */
	uint32_t
	    depth; /* random: deepest nesting, 2..BC_GEN_RANDOM_MAX_DEPTH */
};

/* Which options a generator reads (struct bc_gen_info.takes). */
enum bc_gen_opt {
	BC_GEN_OPT_LEVEL = 1u << 0,
	BC_GEN_OPT_COUNT = 1u << 1,
	BC_GEN_OPT_SEED = 1u << 2,
	BC_GEN_OPT_KIND = 1u << 3,
	BC_GEN_OPT_BLEND = 1u << 4,
	BC_GEN_OPT_TEETH = 1u << 5,
	BC_GEN_OPT_DEPTH = 1u << 6,
};

struct bc_gen_info {
	const char *name;    /* "fig16" */
	const char *usage;   /* "[--level L] [--blend sharp|smooth] ..." */
	const char *summary; /* one sentence, defaults included */
	unsigned takes;      /* enum bc_gen_opt bits */
};

/* The generators, in a static table of *n entries. */
const struct bc_gen_info *bc_gen_list(size_t *n);
/* The generator called name, or NULL. */
const struct bc_gen_info *bc_gen_find(const char *name);

/* Parse "boxes" / "sharp" ...; the _DEFAULT value (0) for unknown names. */
enum bc_gen_kind bc_gen_kind_from_name(const char *name);
enum bc_gen_blend bc_gen_blend_from_name(const char *name);

/*
 * Builds scene name with opts (NULL: all defaults) into t and a camera that
 * frames it into *cam (may be NULL). Returns 0, BC_ENOTFOUND (no such
 * generator), BC_EINVAL (an option the generator does not take),
 * BC_ERANGE (an option out of range), BC_ELIMIT (more than
 * BC_GEN_MAX_PRIMS primitives) or BC_ENOMEM, with the reason in ei; the
 * tree is left empty on failure.
 */
int bc_gen(const char *name, const struct bc_gen_opts *opts, struct bc_tree *t,
           struct bc_camera *cam, struct bc_errinfo *ei);

#endif
