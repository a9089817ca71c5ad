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
#include "blobcast/blobtree.h"
#include "blobcast/gen.h"
#include "blobcast/scene.h"

#define EXIT_USAGE 2

static void usage(FILE *f)
{
	size_t n;
	const struct bc_gen_info *g = bc_gen_list(&n);
	fprintf(f,
	        "usage: blobcast gen NAME [options] [--out FILE]\n"
	        "\n"
	        "Builds a scene and prints it as a JSON scene file (or writes "
	        "it to FILE,\natomically). The same options always give the "
	        "same scene.\n"
	        "\n"
	        "generators:\n");
	for (size_t i = 0; i < n; i++) {
		fprintf(f, "  %s %s\n      %s\n", g[i].name, g[i].usage,
		        g[i].summary);
	}
	fprintf(f, "  default\n      the built-in scene blobcastd's new "
	           "sessions start with\n");
	fprintf(
	    f,
	    "\n"
	    "options (each generator takes only those listed with it):\n"
	    "  --level L   fig16 recursion level, 1..%d\n"
	    "  --count N   number of instances, primitives or gears\n"
	    "  --seed S    random seed, 0..2^64-1 (default 0)\n"
	    "  --kind K    fig18 instance shape: boxes, spheres or lenses\n"
	    "  --blend B   sharp or smooth operators\n"
	    "  --teeth T   teeth of the largest gear, 6..%u\n"
	    "  --depth D   random: deepest nesting, 2..%d\n"
	    "  --out FILE  write to FILE instead of stdout (\"-\": stdout)\n"
	    "  --help      this text\n",
	    BC_GEN_MAX_LEVEL, BC_GEN_MAX_TEETH, BC_TREE_MAX_DEPTH);
}

/* Parses a decimal unsigned number in [lo, hi]. */
static bool parse_u64(const char *s, uint64_t lo, uint64_t hi, uint64_t *out)
{
	char *end = NULL;
	unsigned long long v;
	if (!s || !*s || *s == '-' || *s == '+') {
		return false;
	}
	errno = 0;
	v = strtoull(s, &end, 10);
	if (errno || *end != '\0' || v < lo || v > hi) {
		return false;
	}
	*out = (uint64_t)v;
	return true;
}

/* Matches "--name VALUE" and "--name=VALUE"; advances *i past the value. */
static bool take_value(int argc, char **argv, int *i, const char *name,
                       const char **value, bool *missing)
{
	const char *a = argv[*i];
	size_t n = strlen(name);
	if (strncmp(a, name, n) != 0) {
		return false;
	}
	if (a[n] == '=') {
		*value = a + n + 1;
		return true;
	}
	if (a[n] != '\0') {
		return false;
	}
	if (*i + 1 >= argc) {
		*missing = true;
		*value = NULL;
		return true;
	}
	*value = argv[++*i];
	return true;
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
	struct bc_gen_opts o;
	struct bc_errinfo ei = {0};
	struct bc_camera cam;
	struct bc_tree *t = NULL;
	const struct bc_gen_info *info;
	const char *name = NULL, *out = NULL;
	char *text = NULL;
	int rc, status = 0;

	memset(&o, 0, sizeof(o));
	for (int i = 1; i < argc; i++) {
		const char *a = argv[i], *v = NULL;
		bool missing = false;
		uint64_t x = 0;
		if (strcmp(a, "--help") == 0 || strcmp(a, "-h") == 0) {
			usage(stdout);
			return 0;
		}
		if (a[0] != '-') {
			if (name) {
				fprintf(stderr,
				        "blobcast gen: one generator only "
				        "(got \"%s\" and \"%s\")\n",
				        name, a);
				return EXIT_USAGE;
			}
			name = a;
			continue;
		}
		if (take_value(argc, argv, &i, "--level", &v, &missing)) {
			if (missing || !parse_u64(v, 1, BC_GEN_MAX_LEVEL, &x)) {
				goto bad_value;
			}
			o.level = (uint32_t)x;
		} else if (take_value(argc, argv, &i, "--count", &v,
		                      &missing)) {
			if (missing || !parse_u64(v, 1, BC_GEN_MAX_PRIMS, &x)) {
				goto bad_value;
			}
			o.count = (uint32_t)x;
		} else if (take_value(argc, argv, &i, "--seed", &v, &missing)) {
			if (missing || !parse_u64(v, 0, UINT64_MAX, &x)) {
				goto bad_value;
			}
			o.seed = x;
		} else if (take_value(argc, argv, &i, "--teeth", &v,
		                      &missing)) {
			if (missing || !parse_u64(v, 6, BC_GEN_MAX_TEETH, &x)) {
				goto bad_value;
			}
			o.teeth = (uint32_t)x;
		} else if (take_value(argc, argv, &i, "--depth", &v,
		                      &missing)) {
			if (missing ||
			    !parse_u64(v, 2, BC_TREE_MAX_DEPTH, &x)) {
				goto bad_value;
			}
			o.depth = (uint32_t)x;
		} else if (take_value(argc, argv, &i, "--kind", &v, &missing)) {
			if (missing || (o.kind = bc_gen_kind_from_name(v)) ==
			                   BC_GEN_KIND_DEFAULT) {
				goto bad_value;
			}
		} else if (take_value(argc, argv, &i, "--blend", &v,
		                      &missing)) {
			if (missing || (o.blend = bc_gen_blend_from_name(v)) ==
			                   BC_GEN_BLEND_DEFAULT) {
				goto bad_value;
			}
		} else if (take_value(argc, argv, &i, "--out", &v, &missing)) {
			if (missing || !*v) {
				goto bad_value;
			}
			out = v;
		} else {
			fprintf(stderr,
			        "blobcast gen: unknown option \"%s\" (see "
			        "blobcast gen --help)\n",
			        a);
			return EXIT_USAGE;
		}
		continue;
	bad_value:
		fprintf(stderr,
		        "blobcast gen: %s needs a valid value%s%s%s (see "
		        "blobcast gen --help)\n",
		        a, v ? ", not \"" : "", v ? v : "", v ? "\"" : "");
		return EXIT_USAGE;
	}
	if (!name) {
		fprintf(stderr, "blobcast gen: which generator?\n");
		usage(stderr);
		return EXIT_USAGE;
	}
	if (strcmp(name, "default") == 0) {
		const char *json = bc_scene_default_json();
		/* blobcastd's built-in scene, which new sessions start with;
		 * it takes no generator options. */
		if (o.level || o.count || o.seed || o.teeth || o.depth ||
		    o.kind || o.blend) {
			fprintf(stderr,
			        "blobcast gen: default takes no options "
			        "but --out\n");
			return EXIT_USAGE;
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
		fprintf(stderr,
		        "blobcast gen: no generator called \"%s\" (see "
		        "blobcast gen --help)\n",
		        name);
		return EXIT_USAGE;
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
