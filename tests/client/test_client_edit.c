/*
 * key=value edits: names map to the protocol's field numbers by the kind of
 * the node in the scene (parameter k of bc_prim_info -> PARAM0 + k), values
 * are parsed strictly, and the fields produced are ones the protocol
 * encoder accepts. Malformed arguments are refused with a reason.
 */
#include <string.h>

#include "blobcast/client.h"
#include "blobcast/scene.h"
#include "test.h"

static const char scene_json[] =
    "{\"blobcast\": 1, \"root\": {\"type\": \"smooth_union\", \"id\": 1, "
    "\"blend\": 0.2, \"children\": ["
    "{\"type\": \"sphere\", \"id\": 2, \"radius\": 0.5},"
    "{\"type\": \"box\", \"id\": 3, \"half_extents\": [0.3, 0.3, 0.3],"
    " \"translate\": [1, 0, 0]},"
    "{\"type\": \"capsule\", \"id\": 4, \"a\": [0, 0, 0],"
    " \"b\": [0, 1, 0], \"radius\": 0.1}]}}";

static struct bc_tree *scene(void)
{
	struct bc_tree *t = bc_tree_create();
	struct bc_errinfo ei = {0};
	if (t && bc_scene_parse_json(scene_json, strlen(scene_json), t, NULL,
	                             &ei) != 0) {
		fprintf(stderr, "  scene: %s\n", ei.msg);
		bc_tree_destroy(t);
		t = NULL;
	}
	return t;
}

/* Field number of the parameter called name of kind, from blobtree's own
 * description (the order docs/primitives.md gives). */
static int param_field(enum bc_prim kind, const char *name, int *count)
{
	const struct bc_prim_info *info = bc_prim_info(kind);
	for (int k = 0; info && k < info->nparams; k++) {
		if (strcmp(info->params[k].name, name) == 0) {
			*count = info->params[k].count;
			return (int)BC_PROTO_FIELD_PARAM0 + k;
		}
	}
	return -1;
}

static int parse(const struct bc_tree *t, uint32_t node, const char *a,
                 const char *b, struct bc_proto_field *f, uint8_t *n,
                 struct bc_errinfo *ei)
{
	const char *kv[2] = {a, b};
	return bc_client_edit_parse(t, node, kv, b ? 2u : 1u, f, n, ei);
}

/* The fields make a valid EDIT for the wire. */
static void encodes(uint32_t node, const struct bc_proto_field *f, uint8_t n)
{
	struct bc_proto_buf b;
	struct bc_proto_edit_op op = {.kind = BC_PROTO_EDIT_SET};
	struct bc_msg m = {.type = BC_MSG_EDIT, .seq = 1};
	struct bc_errinfo ei = {0};
	op.node = node;
	op.nfields = n;
	op.fields = f;
	m.edit.nops = 1;
	m.edit.ops = &op;
	bc_proto_buf_init(&b, 0);
	if (bc_proto_encode(&b, &m, &ei) != 0) {
		fprintf(stderr, "  encode: %s\n", ei.msg);
		CHECK(0);
	}
	bc_proto_buf_finish(&b);
}

static void test_primitive_parameters_map_by_kind(void)
{
	struct bc_tree *t = scene();
	struct bc_proto_field f[BC_PROTO_MAX_SET_FIELDS];
	struct bc_errinfo ei = {0};
	uint8_t n = 99;
	int count = 0, field;
	REQUIRE(t);
	field = param_field(BC_PRIM_SPHERE, "radius", &count);
	REQUIRE(field >= (int)BC_PROTO_FIELD_PARAM0);
	REQUIRE(parse(t, 2, "radius=0.4", NULL, f, &n, &ei) == 0);
	CHECK_EQ_INT(n, 1);
	CHECK_EQ_INT(f[0].field, field);
	CHECK_EQ_INT(f[0].count, 1);
	CHECK(f[0].v[0] == 0.4f);
	encodes(2, f, n);

	/* The same name on another kind maps by that kind's layout. */
	field = param_field(BC_PRIM_CAPSULE, "radius", &count);
	REQUIRE(field >= 0);
	REQUIRE(parse(t, 4, "radius=0.25", "b=0,2,0", f, &n, &ei) == 0);
	CHECK_EQ_INT(n, 2);
	CHECK_EQ_INT(f[0].field, field);
	field = param_field(BC_PRIM_CAPSULE, "b", &count);
	CHECK_EQ_INT(f[1].field, field);
	CHECK_EQ_INT(f[1].count, 3);
	CHECK(f[1].v[0] == 0.0f && f[1].v[1] == 2.0f && f[1].v[2] == 0.0f);
	encodes(4, f, n);

	field = param_field(BC_PRIM_BOX, "half_extents", &count);
	REQUIRE(field >= 0 && count == 3);
	REQUIRE(parse(t, 3, "half_extents=0.5,0.25,1e-1", NULL, f, &n, &ei) ==
	        0);
	CHECK_EQ_INT(f[0].field, field);
	CHECK(f[0].v[0] == 0.5f && f[0].v[1] == 0.25f && f[0].v[2] == 0.1f);
	encodes(3, f, n);
	bc_tree_destroy(t);
}

static void test_transform_and_colour_fields(void)
{
	struct bc_tree *t = scene();
	const char *kv[3] = {"translate=0.1,0,-2", "rotate=0,0,0.6,0.8",
	                     "color=1,0.5,0"};
	struct bc_proto_field f[BC_PROTO_MAX_SET_FIELDS];
	struct bc_errinfo ei = {0};
	uint8_t n;
	REQUIRE(t);
	REQUIRE(bc_client_edit_parse(t, 3, kv, 3, f, &n, &ei) == 0);
	CHECK_EQ_INT(n, 3);
	CHECK_EQ_INT(f[0].field, BC_PROTO_FIELD_TRANSLATE);
	CHECK_EQ_INT(f[0].count, 3);
	CHECK(f[0].v[0] == 0.1f && f[0].v[2] == -2.0f);
	CHECK_EQ_INT(f[1].field, BC_PROTO_FIELD_ROTATE);
	CHECK_EQ_INT(f[1].count, 4);
	CHECK(f[1].v[2] == 0.6f && f[1].v[3] == 0.8f);
	CHECK_EQ_INT(f[2].field, BC_PROTO_FIELD_COLOR);
	CHECK(f[2].v[1] == 0.5f);
	encodes(3, f, n);
	bc_tree_destroy(t);
}

static void test_operator_fields(void)
{
	struct bc_tree *t = scene();
	const char *kv[3] = {"blend=0.3", "range=0.5", "kind=smooth_union"};
	struct bc_proto_field f[BC_PROTO_MAX_SET_FIELDS];
	struct bc_errinfo ei = {0};
	uint8_t n;
	REQUIRE(t);
	REQUIRE(bc_client_edit_parse(t, 1, kv, 3, f, &n, &ei) == 0);
	CHECK_EQ_INT(n, 3);
	CHECK_EQ_INT(f[0].field, BC_PROTO_FIELD_BLEND);
	CHECK(f[0].v[0] == 0.3f);
	CHECK_EQ_INT(f[1].field, BC_PROTO_FIELD_RANGE);
	CHECK_EQ_INT(f[2].field, BC_PROTO_FIELD_OP_KIND);
	CHECK(f[2].v[0] == (float)BC_OP_SMOOTH_UNION);
	encodes(1, f, n);
	REQUIRE(parse(t, 1, "kind=2", NULL, f, &n, &ei) == 0);
	CHECK(f[0].v[0] == 2.0f);
	CHECK_EQ_INT(parse(t, 1, "kind=15", NULL, f, &n, &ei), BC_EINVAL);
	CHECK_EQ_INT(parse(t, 1, "kind=blob", NULL, f, &n, &ei), BC_EINVAL);
	/* Primitive keys do not apply to operators, nor the reverse. */
	CHECK_EQ_INT(parse(t, 1, "radius=1", NULL, f, &n, &ei), BC_EINVAL);
	CHECK(strstr(ei.msg, "blend") != NULL);
	CHECK_EQ_INT(parse(t, 2, "blend=1", NULL, f, &n, &ei), BC_EINVAL);
	CHECK(strstr(ei.msg, "radius") != NULL);
	bc_tree_destroy(t);
}

static void refused(const struct bc_tree *t, uint32_t node, const char *a,
                    const char *b, int code)
{
	struct bc_proto_field f[BC_PROTO_MAX_SET_FIELDS];
	struct bc_errinfo ei = {0};
	uint8_t n = 7;
	int rc = parse(t, node, a, b, f, &n, &ei);
	if (rc != code) {
		fprintf(stderr, "  \"%s\" \"%s\": got %s (%s), wanted %s\n",
		        a ? a : "", b ? b : "", bc_err_name(rc), ei.msg,
		        bc_err_name(code));
	}
	CHECK_EQ_INT(rc, code);
	CHECK(ei.msg[0] != '\0');
	if (!b) {
		CHECK_EQ_INT(n, 0); /* reset on entry */
	}
}

static void test_malformed_arguments_are_refused(void)
{
	struct bc_tree *t = scene();
	REQUIRE(t);
	refused(t, 2, "radius", NULL, BC_EINVAL);
	refused(t, 2, "=0.4", NULL, BC_EINVAL);
	refused(t, 2, "radiuss=0.4", NULL, BC_EINVAL);
	refused(t, 2, "Radius=0.4", NULL, BC_EINVAL);
	refused(t, 2, "radius=", NULL, BC_EPARSE);
	refused(t, 2, "radius=abc", NULL, BC_EPARSE);
	refused(t, 2, "radius=0.4x", NULL, BC_EPARSE);
	refused(t, 2, "radius= 0.4", NULL, BC_EPARSE);
	refused(t, 2, "radius=0.4,", NULL, BC_EPARSE);
	refused(t, 2, "radius=0.4,0.5", NULL, BC_EINVAL);
	refused(t, 2, "radius=nan", NULL, BC_ENONFINITE);
	refused(t, 2, "radius=inf", NULL, BC_ENONFINITE);
	refused(t, 2, "radius=1e39", NULL, BC_ENONFINITE);
	refused(t, 2, "radius=2e6", NULL, BC_ERANGE);
	refused(t, 2, "translate=1,2", NULL, BC_EINVAL);
	refused(t, 2, "translate=1,,2", NULL, BC_EPARSE);
	refused(t, 2, "rotate=0,0,0,1,0", NULL, BC_EINVAL);
	refused(t, 2, "radius=0.4", "radius=0.5", BC_EINVAL);
	refused(t, 99, "radius=0.4", NULL, BC_ENONODE);
	refused(t, 0, "radius=0.4", NULL, BC_ENONODE);
	refused(NULL, 2, "radius=0.4", NULL, BC_ENONODE);
	bc_tree_destroy(t);
}

static void test_argument_counts_are_bounded(void)
{
	struct bc_tree *t = scene();
	const char *kv[BC_CLIENT_MAX_EDIT_ARGS + 1];
	struct bc_proto_field f[BC_PROTO_MAX_SET_FIELDS];
	struct bc_errinfo ei = {0};
	uint8_t n = 5;
	REQUIRE(t);
	CHECK_EQ_INT(bc_client_edit_parse(t, 2, kv, 0, f, &n, &ei), BC_EINVAL);
	CHECK_EQ_INT(n, 0);
	/* The message lists what the node takes. */
	CHECK(strstr(ei.msg, "radius") && strstr(ei.msg, "translate"));
	for (size_t i = 0; i < BC_CLIENT_MAX_EDIT_ARGS + 1; i++) {
		kv[i] = "radius=1";
	}
	CHECK_EQ_INT(bc_client_edit_parse(t, 2, kv, BC_CLIENT_MAX_EDIT_ARGS + 1,
	                                  f, &n, &ei),
	             BC_ELIMIT);
	bc_tree_destroy(t);
}

/* Every parameter name of every kind maps to its own field, with the count
 * the kind declares, and the result encodes. */
static void test_every_kind_every_parameter(void)
{
	int built = 0;
	for (int kind = 1; kind < BC_PRIM_COUNT; kind++) {
		const struct bc_prim_info *info =
		    bc_prim_info((enum bc_prim)kind);
		struct bc_tree *t = bc_tree_create();
		struct bc_prim_data p;
		struct bc_errinfo ei = {0};
		REQUIRE(info && t);
		bc_prim_data_init(&p, (enum bc_prim)kind);
		/* Distinct, decreasing small positive values make a valid
		 * shape of every kind: segment ends differ, radii and angles
		 * are small, and a rounding or thickness that follows the
		 * extents it must not exceed is smaller than them. */
		for (int k = 0; k < BC_PRIM_MAX_PARAMS; k++) {
			p.params[k] = 0.5f - 0.04f * (float)k;
		}
		if (bc_prim_validate(&p, NULL) != 0) {
			/* Kinds with whole-number or ordered parameters
			 * (polygon sides, a vesica's width): the defaults. */
			bc_prim_data_init(&p, (enum bc_prim)kind);
		}
		if (bc_tree_begin(t) || bc_tree_put_prim(t, 5, &p, &ei) ||
		    bc_tree_end(t, &ei)) {
			fprintf(stderr, "  %s: %s\n", info->name, ei.msg);
			CHECK(0);
			bc_tree_destroy(t);
			continue;
		}
		built++;
		for (int k = 0; k < info->nparams; k++) {
			const struct bc_param_desc *d = &info->params[k];
			struct bc_proto_field f[BC_PROTO_MAX_SET_FIELDS];
			char arg[96];
			const char *kv[1] = {arg};
			uint8_t n;
			snprintf(arg, sizeof(arg), "%s=%s", d->name,
			         d->count == 1 ? "0.5" : "0.5,0.25,0.125");
			if (bc_client_edit_parse(t, 5, kv, 1, f, &n, &ei) !=
			    0) {
				fprintf(stderr, "  %s.%s: %s\n", info->name,
				        d->name, ei.msg);
				CHECK(0);
				continue;
			}
			CHECK_EQ_INT(f[0].field, BC_PROTO_FIELD_PARAM0 + k);
			CHECK_EQ_INT(f[0].count, d->count);
			encodes(5, f, n);
		}
		bc_tree_destroy(t);
	}
	CHECK_EQ_INT(built, BC_PRIM_COUNT - 1);
}

static const struct bc_test tests[] = {
    {"primitive_parameters_map_by_kind", test_primitive_parameters_map_by_kind},
    {"transform_and_colour_fields", test_transform_and_colour_fields},
    {"operator_fields", test_operator_fields},
    {"malformed_arguments_are_refused", test_malformed_arguments_are_refused},
    {"argument_counts_are_bounded", test_argument_counts_are_bounded},
    {"every_kind_every_parameter", test_every_kind_every_parameter},
};

BC_TEST_MAIN(tests)
