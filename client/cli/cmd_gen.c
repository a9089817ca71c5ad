/*
 * `blobcast gen NAME [options] [--out FILE]`: command-line front of the
 * scene generators. It owns option parsing (strict: every value is checked,
 * options a generator does not read are refused) and the output, a JSON
 * scene file on stdout or written atomically to FILE.
 */
#include "cmd_gen.h"

#include <errno.h>
#include <inttypes.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "blobcast/alloc.h"
#include "blobcast/args.h"
#include "blobcast/blobtree.h"
#include "blobcast/gen.h"
#include "blobcast/scene.h"

#define EXIT_USAGE 2

static const struct bc_opt_name kind_names[] = {
    {"boxes", BC_GEN_KIND_BOXES},
    {"spheres", BC_GEN_KIND_SPHERES},
    {"lenses", BC_GEN_KIND_LENSES},
    {NULL, 0}};
static const struct bc_opt_name blend_names[] = {
    {"sharp", BC_GEN_BLEND_SHARP}, {"smooth", BC_GEN_BLEND_SMOOTH}, {NULL, 0}};

struct gen_args {
	struct bc_gen_opts o;
	int kind, blend;
	const char *out;
};

/* The option table over a; --help is generated from it. */
#define GEN_OPTS(a)                                                            \
	{                                                                      \
		{.name = "level",                                              \
		 .kind = BC_OPT_U32,                                           \
		 .dst = &(a)->o.level,                                         \
		 .lo = 1,                                                      \
		 .hi = BC_GEN_MAX_LEVEL,                                       \
		 .arg = "L",                                                   \
		 .help = "fig16 recursion level, {range}"},                    \
		    {.name = "count",                                          \
		     .kind = BC_OPT_U32,                                       \
		     .dst = &(a)->o.count,                                     \
		     .lo = 1,                                                  \
		     .hi = BC_GEN_MAX_PRIMS,                                   \
		     .arg = "N",                                               \
		     .help = "number of instances, primitives or gears,\n"     \
		             "{range}"},                                       \
		    {.name = "seed",                                           \
		     .kind = BC_OPT_U64,                                       \
		     .dst = &(a)->o.seed,                                      \
		     .arg = "S",                                               \
		     .help = "random seed, {range} (default 0)"},              \
		    {.name = "kind",                                           \
		     .kind = BC_OPT_ENUM,                                      \
		     .dst = &(a)->kind,                                        \
		     .arg = "K",                                               \
		     .help = "fig18 instance shape: {choices}",                \
		     .names = kind_names},                                     \
		    {.name = "blend",                                          \
		     .kind = BC_OPT_ENUM,                                      \
		     .dst = &(a)->blend,                                       \
		     .arg = "B",                                               \
		     .help = "{choices} operators",                            \
		     .names = blend_names},                                    \
		    {.name = "teeth",                                          \
		     .kind = BC_OPT_U32,                                       \
		     .dst = &(a)->o.teeth,                                     \
		     .lo = 6,                                                  \
		     .hi = BC_GEN_MAX_TEETH,                                   \
		     .arg = "T",                                               \
		     .help = "teeth of the largest gear, {range}"},            \
		    {.name = "depth",                                          \
		     .kind = BC_OPT_U32,                                       \
		     .dst = &(a)->o.depth,                                     \
		     .lo = 2,                                                  \
		     .hi = BC_GEN_RANDOM_MAX_DEPTH,                            \
		     .arg = "D",                                               \
		     .help = "random: deepest nesting, {range}"},              \
		    {.name = "out",                                            \
		     .kind = BC_OPT_STRING,                                    \
		     .dst = &(a)->out,                                         \
		     .arg = "FILE",                                            \
		     .help =                                                   \
		         "write to FILE instead of stdout (\"-\": stdout)"},   \
		    {.kind = BC_OPT_INVALID},                                  \
	}

/* The generators and what each takes, between the usage line and the
 * options; built from bc_gen_list() so it lists every one built in. */
static const char *gen_about(char *buf, size_t cap)
{
	size_t n, len;
	const struct bc_gen_info *g = bc_gen_list(&n);
	len = (size_t)snprintf(buf, cap,
	                       "Builds a scene and prints it as a JSON scene "
	                       "file (or writes it to FILE,\natomically). The "
	                       "same options always give the same scene.\n\n"
	                       "generators:\n");
	for (size_t i = 0; i < n && len < cap; i++) {
		len += (size_t)snprintf(buf + len, cap - len,
		                        "  %s %s\n      %s\n", g[i].name,
		                        g[i].usage, g[i].summary);
	}
	if (len < cap) {
		snprintf(buf + len, cap - len,
		         "  default\n      the built-in scene blobcastd's new "
		         "sessions start with\n\noptions (each generator "
		         "takes only those listed with it):");
	}
	return buf;
}

static struct bc_args gen_args(const struct bc_opt *opts, char *about,
                               size_t cap)
{
	return (struct bc_args){.prog = "blobcast gen",
	                        .usage =
	                            "blobcast gen NAME [options] [--out FILE]",
	                        .about = gen_about(about, cap),
	                        .opts = opts};
}

static int write_stdout(const char *text)
{
	size_t len = strlen(text);
	if (fwrite(text, 1, len, stdout) != len || fflush(stdout) != 0) {
		fprintf(stderr, "blobcast gen: writing to stdout: %s\n",
		        strerror(errno));
		return 1;
	}
	return 0;
}

int bc_cli_gen(int argc, char **argv)
{
	struct gen_args a = {.out = NULL};
	const struct bc_opt opts[] = GEN_OPTS(&a);
	char about[4096];
	struct bc_args p = gen_args(opts, about, sizeof(about));
	struct bc_gen_opts o;
	struct bc_errinfo ei = {0};
	struct bc_camera cam;
	struct bc_tree *t = NULL;
	const struct bc_gen_info *info;
	const char *name, *out;
	char *text = NULL;
	int rc, status = 0;

	if (bc_args_parse(&p, argc, argv)) {
		return p.status;
	}
	if (p.npos == 0) {
		return bc_args_error(&p, "which generator?");
	}
	if (p.npos > 1) {
		return bc_args_error(&p,
		                     "one generator only (got '%s' and "
		                     "'%s')",
		                     p.pos[0], p.pos[1]);
	}
	name = p.pos[0];
	out = a.out;
	o = a.o;
	o.kind = (enum bc_gen_kind)a.kind;
	o.blend = (enum bc_gen_blend)a.blend;
	if (strcmp(name, "default") == 0) {
		const char *json = bc_scene_default_json();
		/* blobcastd's built-in scene, which new sessions start with;
		 * it takes no generator options. */
		if (o.level || o.count || o.seed || o.teeth || o.depth ||
		    o.kind || o.blend) {
			return bc_args_error(&p, "default takes no options "
			                         "but --out");
		}
		if (!(t = bc_tree_create())) {
			fprintf(stderr, "blobcast gen: out of memory\n");
			return 1;
		}
		if (bc_scene_parse_json(json, strlen(json), t, &cam, &ei)) {
			fprintf(stderr, "blobcast gen: %s\n", ei.msg);
			status = 1;
			goto cleanup;
		}
		goto write;
	}
	if (!(info = bc_gen_find(name))) {
		return bc_args_error(&p, "no generator called '%s'", name);
	}
	if (!(t = bc_tree_create())) {
		fprintf(stderr, "blobcast gen: out of memory\n");
		return 1;
	}
	rc = bc_gen(name, &o, t, &cam, &ei);
	if (rc) {
		fprintf(stderr, "blobcast gen: %s\n", ei.msg);
		/* Bad or inapplicable options are the user's to fix. */
		status = (rc == BC_EINVAL || rc == BC_ERANGE || rc == BC_ELIMIT)
		             ? EXIT_USAGE
		             : 1;
		goto cleanup;
	}
write:
	if (out && strcmp(out, "-") != 0) {
		if ((rc = bc_scene_save_json(out, t, &cam, &ei))) {
			fprintf(stderr, "blobcast gen: %s\n", ei.msg);
			status = 1;
		}
		goto cleanup;
	}
	if (!(text = bc_scene_to_json(t, &cam))) {
		fprintf(stderr, "blobcast gen: out of memory\n");
		status = 1;
		goto cleanup;
	}
	status = write_stdout(text);
cleanup:
	bc_free(text);
	bc_tree_destroy(t);
	return status;
}
