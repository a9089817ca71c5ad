/*
 * What a SET operation says (PROTOCOL.md section 9), in one table: each
 * field's number, the key people type for it (`blobcast edit ID key=value`,
 * libblobcast's bc_client_edit_parse) and that scene files use, how many
 * values it takes and which nodes it applies to; and the node kinds the
 * OP_KIND field and the scene encoding number. The decoder, the edit module
 * (what the daemon applies and every mirror replays), the CLI and the tests
 * read this table instead of keeping their own lists, and the static
 * assertions below fail the build when a row and a limit disagree.
 * tests/web/prims.test.mjs reads the table and checks the browser page's
 * copy of it (client/web/protocol.js).
 */
#ifndef BLOBCAST_PROTO_FIELDS_H
#define BLOBCAST_PROTO_FIELDS_H

#include <stddef.h>
#include <stdint.h>

#include "blobcast/proto_limits.h"

/* ---- Node kinds ----------------------------------------------------------
 */

/* Operator kinds as the scene encoding and the OP_KIND field number them
 * (the same numbers as blobtree's enum bc_op): 1..6 binary, 7..14 unary
 * and domain nodes (offset .. scale), which carry nfloats parameters (at
 * most BC_PROTO_MAX_UNARY_PARAMS) and exactly one child. The edit module
 * asserts at compile time that blobtree agrees. */
#define BC_PROTO_OP_KIND_MAX 14u
#define BC_PROTO_OP_KIND_FIRST_UNARY 7u
#define BC_PROTO_MAX_UNARY_PARAMS 6u
/* Primitive kinds run 1..32 (blobtree's enum bc_prim). */
#define BC_PROTO_PRIM_KIND_MAX 32u

/* ---- Field numbers -------------------------------------------------------
 */

/* Field numbers of a set operation (sparse, so not an enum). Parameter k
 * (0-based, in the order of docs/primitives.md) is BC_PROTO_FIELD_PARAM0 + k,
 * k < BC_PROTO_MAX_PRIM_PARAMS. Each number is written here once; the table
 * below says the rest. */
#define BC_PROTO_FIELD_TRANSLATE 1u
#define BC_PROTO_FIELD_ROTATE 2u /* quaternion x y z w */
#define BC_PROTO_FIELD_COLOR 3u
#define BC_PROTO_FIELD_PARAM0 16u /* 16..23 */
#define BC_PROTO_FIELD_BLEND 32u
#define BC_PROTO_FIELD_RANGE 33u
#define BC_PROTO_FIELD_OP_KIND 34u /* an integer 1..BC_PROTO_OP_KIND_MAX */

/* Which nodes a field applies to (the table's last column). */
#define BC_PROTO_ON_PRIM 0x01u  /* primitives */
#define BC_PROTO_ON_OP 0x02u    /* binary operators */
#define BC_PROTO_ON_UNARY 0x04u /* unary and domain nodes */
/* The field's key is also a member of a scene file's node, with the same
 * values (OP_KIND is not: a scene file names a kind by "type"). */
#define BC_PROTO_IN_SCENE 0x08u

/*
 * The SET fields, in field-number order:
 *   X(NAME, key, min_values, max_values, numbers, flags)
 * NAME: BC_PROTO_FIELD_NAME is the first field number of the row; numbers:
 * how many consecutive field numbers the row covers (the shape parameters
 * cover BC_PROTO_MAX_PRIM_PARAMS); key: what people type, NULL where the
 * node's kind names each number (a primitive's parameter names, blobtree's
 * bc_prim_info; a unary node's, bc_unary_info); min_values..max_values:
 * the value counts the decoder accepts (the edit module then requires the
 * exact count of the node's kind); flags: BC_PROTO_ON_* and
 * BC_PROTO_IN_SCENE.
 */
#define BC_PROTO_FIELDS(X)                                                     \
	X(TRANSLATE, "translate", 3, 3, 1,                                     \
	  BC_PROTO_ON_PRIM | BC_PROTO_IN_SCENE)                                \
	X(ROTATE, "rotate", 4, 4, 1, BC_PROTO_ON_PRIM | BC_PROTO_IN_SCENE)     \
	X(COLOR, "color", 3, 3, 1, BC_PROTO_ON_PRIM | BC_PROTO_IN_SCENE)       \
	X(PARAM0, NULL, 1, BC_PROTO_MAX_FIELD_VALUES,                          \
	  BC_PROTO_MAX_PRIM_PARAMS,                                            \
	  BC_PROTO_ON_PRIM | BC_PROTO_ON_UNARY | BC_PROTO_IN_SCENE)            \
	X(BLEND, "blend", 1, 1, 1, BC_PROTO_ON_OP | BC_PROTO_IN_SCENE)         \
	X(RANGE, "range", 1, 1, 1, BC_PROTO_ON_OP | BC_PROTO_IN_SCENE)         \
	X(OP_KIND, "kind", 1, 1, 1, BC_PROTO_ON_OP | BC_PROTO_ON_UNARY)

/* BC_PROTO_FIELD_<NAME>_VALUES: the most values the row's fields take
 * (translate 3, rotate 4, ...), for arrays and checks sized by a field. */
#define BC_PROTO_FIELD_VALUES_(name, key, lo, hi, n, flags)                    \
	BC_PROTO_FIELD_##name##_VALUES = (hi),
enum { BC_PROTO_FIELDS(BC_PROTO_FIELD_VALUES_) };
#undef BC_PROTO_FIELD_VALUES_

/* One row of the table, as bc_proto_field_info() returns it. */
struct bc_proto_field_info {
	uint8_t first;      /* BC_PROTO_FIELD_<NAME> */
	uint8_t numbers;    /* field numbers first .. first + numbers - 1 */
	uint8_t min_values; /* value counts the decoder accepts */
	uint8_t max_values;
	uint8_t flags;   /* BC_PROTO_ON_*, BC_PROTO_IN_SCENE */
	const char *key; /* NULL: the node's kind names the field */
};

/* The row of field number field, or NULL when field is not a field
 * number. Points to static data (nothing to free). */
static inline const struct bc_proto_field_info *
bc_proto_field_info(unsigned field)
{
#define BC_PROTO_FIELD_ROW_(name, k, lo, hi, n, fl)                            \
	{.first = BC_PROTO_FIELD_##name,                                       \
	 .numbers = (n),                                                       \
	 .min_values = (lo),                                                   \
	 .max_values = (hi),                                                   \
	 .flags = (fl),                                                        \
	 .key = (k)},
	static const struct bc_proto_field_info rows[] = {
	    BC_PROTO_FIELDS(BC_PROTO_FIELD_ROW_)};
#undef BC_PROTO_FIELD_ROW_
	for (size_t i = 0; i < sizeof(rows) / sizeof(rows[0]); i++) {
		if (field >= rows[i].first &&
		    field - rows[i].first < rows[i].numbers) {
			return &rows[i];
		}
	}
	return NULL;
}

/* ---- What must agree -----------------------------------------------------
 */

/* The field numbers the rows cover, as one bit each (the decoder and the
 * key=value parser track "given twice" in a 64-bit mask), their count, and
 * the sum of the rows' masks: equal to the union only when no two rows
 * share a number. */
#define BC_PROTO_FIELD_MASK_(name, key, lo, hi, n, flags)                      \
	| (((UINT64_C(1) << (n)) - 1u) << BC_PROTO_FIELD_##name)
#define BC_PROTO_FIELD_SUM_(name, key, lo, hi, n, flags)                       \
	+(((UINT64_C(1) << (n)) - 1u) << BC_PROTO_FIELD_##name)
#define BC_PROTO_FIELD_COUNT_(name, key, lo, hi, n, flags) +(n)
#define BC_PROTO_FIELD_OK_(name, key, lo, hi, n, flags)                        \
	&&((lo) >= 1 && (lo) <= (hi) && (hi) <= BC_PROTO_MAX_FIELD_VALUES &&   \
	   BC_PROTO_FIELD_##name + (n) <= 64u)

_Static_assert(1 BC_PROTO_FIELDS(BC_PROTO_FIELD_OK_),
               "a field takes 1..BC_PROTO_MAX_FIELD_VALUES values and its "
               "number is below 64");
_Static_assert((0 BC_PROTO_FIELDS(BC_PROTO_FIELD_MASK_)) ==
                   (0 BC_PROTO_FIELDS(BC_PROTO_FIELD_SUM_)),
               "two rows of BC_PROTO_FIELDS share a field number");
_Static_assert((0 BC_PROTO_FIELDS(BC_PROTO_FIELD_COUNT_)) ==
                   BC_PROTO_MAX_SET_FIELDS,
               "BC_PROTO_MAX_SET_FIELDS is the number of field numbers "
               "(each may appear once in a SET)");
_Static_assert(BC_PROTO_FIELD_ROTATE_VALUES == BC_PROTO_MAX_FIELD_VALUES,
               "BC_PROTO_MAX_FIELD_VALUES is the widest field's count");
_Static_assert(BC_PROTO_MAX_UNARY_PARAMS <=
                   BC_PROTO_MAX_PRIM_PARAMS * BC_PROTO_FIELD_PARAM0_VALUES,
               "a unary node's parameters fit its parameter fields");
_Static_assert(BC_PROTO_OP_KIND_FIRST_UNARY > 1 &&
                   BC_PROTO_OP_KIND_FIRST_UNARY <= BC_PROTO_OP_KIND_MAX,
               "binary operators come first, then unary nodes");
_Static_assert(BC_PROTO_OP_KIND_MAX < 128 && BC_PROTO_PRIM_KIND_MAX < 128,
               "a scene record's tag byte holds the kind in 7 bits");
#undef BC_PROTO_FIELD_MASK_
#undef BC_PROTO_FIELD_SUM_
#undef BC_PROTO_FIELD_COUNT_
#undef BC_PROTO_FIELD_OK_

#endif
