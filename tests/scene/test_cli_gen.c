/*
 * `blobcast gen`: prints a scene file that parses back to the generator's
 * scene, writes one with --out, lists every generator in --help, and exits
 * 2 with a message for every kind of bad command line.
 */
#include <fcntl.h>
#include <stdint.h>
#include <sys/stat.h>
#include <unistd.h>

#include "blobcast/alloc.h"
#include "blobcast/blobtree.h"
#include "blobcast/gen.h"
#include "blobcast/scene.h"
#include "cmd_gen.h"
#include "scene_util.h"
#include "test.h"

struct run {
	int status;
	char *out; /* bc_malloc'd stdout text */
	char *err; /* bc_malloc'd stderr text */
};

static char *slurp(const char *path)
{
	FILE *f = fopen(path, "rb");
	char *buf = NULL;
	long n;
	if (!f) {
		return NULL;
	}
	if (fseek(f, 0, SEEK_END) == 0 && (n = ftell(f)) >= 0 &&
	    fseek(f, 0, SEEK_SET) == 0 && (buf = bc_malloc((size_t)n + 1))) {
		size_t got = fread(buf, 1, (size_t)n, f);
		buf[got] = '\0';
	}
	fclose(f);
	return buf;
}

/* Runs bc_cli_gen with args (NULL-terminated, after "gen"), capturing
 * stdout and stderr through temporary files. */
static struct run run_gen(const char *const *args)
{
	char *argv[32];
	int argc = 0, saved_out, saved_err, fo, fe;
	char out_path[] = "/tmp/bc-cli-out-XXXXXX";
	char err_path[] = "/tmp/bc-cli-err-XXXXXX";
	struct run r = {0};
	argv[argc++] = (char *)"gen";
	while (*args && argc < 31) {
		argv[argc++] = (char *)*args++;
	}
	argv[argc] = NULL;
	fo = mkstemp(out_path);
	fe = mkstemp(err_path);
	fflush(stdout);
	fflush(stderr);
	saved_out = dup(STDOUT_FILENO);
	saved_err = dup(STDERR_FILENO);
	dup2(fo, STDOUT_FILENO);
	dup2(fe, STDERR_FILENO);
	r.status = bc_cli_gen(argc, argv);
	fflush(stdout);
	fflush(stderr);
	dup2(saved_out, STDOUT_FILENO);
	dup2(saved_err, STDERR_FILENO);
	close(saved_out);
	close(saved_err);
	close(fo);
	close(fe);
	r.out = slurp(out_path);
	r.err = slurp(err_path);
	unlink(out_path);
	unlink(err_path);
	return r;
}

static void run_free(struct run *r)
{
	bc_free(r->out);
	bc_free(r->err);
}

static void prints_the_generators_scene(void)
{
	static const char *const args[] = {"fig18",          "--count", "30",
	                                   "--kind=spheres", "--blend", "sharp",
	                                   "--seed",         "7",       NULL};
	struct run r = run_gen(args);
	struct bc_tree *t = bc_tree_create(), *ref = bc_tree_create();
	struct bc_gen_opts o = {.count = 30,
	                        .kind = BC_GEN_KIND_SPHERES,
	                        .blend = BC_GEN_BLEND_SHARP,
	                        .seed = 7};
	struct bc_camera cam, cref;
	struct bc_errinfo ei = {0};
	REQUIRE(t && ref && r.out);
	CHECK_EQ_INT(r.status, 0);
	CHECK_EQ_INT(bc_scene_parse_json(r.out, strlen(r.out), t, &cam, &ei),
	             0);
	REQUIRE(bc_gen("fig18", &o, ref, &cref, NULL) == 0);
	CHECK_EQ_INT(tree_diff(ref, t), 0);
	CHECK(same_camera(&cam, &cref));
	run_free(&r);
	bc_tree_destroy(t);
	bc_tree_destroy(ref);
}

static void writes_the_scene_with_out(void)
{
	char dir[] = "/tmp/bc-cli-XXXXXX", path[64];
	const char *args[] = {"gears", "--teeth", "12", "--out", path, NULL};
	struct bc_tree *t = bc_tree_create();
	struct run r;
	REQUIRE(t && mkdtemp(dir));
	snprintf(path, sizeof(path), "%s/g.json", dir);
	r = run_gen(args);
	CHECK_EQ_INT(r.status, 0);
	CHECK(r.out && r.out[0] == '\0');
	CHECK_EQ_INT(bc_scene_load_json(path, t, NULL, NULL), 0);
	CHECK(bc_tree_prim_count(t) > 12);
	run_free(&r);
	/* An unwritable destination is a failure, not a usage error. */
	snprintf(path, sizeof(path), "%s/none/g.json", dir);
	r = run_gen(args);
	CHECK_EQ_INT(r.status, 1);
	CHECK(r.err && strstr(r.err, "none/g.json"));
	run_free(&r);
	snprintf(path, sizeof(path), "%s/g.json", dir);
	unlink(path);
	rmdir(dir);
	bc_tree_destroy(t);
}

static void help_lists_every_generator(void)
{
	static const char *const args[] = {"--help", NULL};
	struct run r = run_gen(args);
	size_t n;
	const struct bc_gen_info *list = bc_gen_list(&n);
	CHECK_EQ_INT(r.status, 0);
	REQUIRE(r.out);
	for (size_t i = 0; i < n; i++) {
		CHECK(strstr(r.out, list[i].name) != NULL);
		CHECK(strstr(r.out, list[i].usage) != NULL);
	}
	CHECK(strstr(r.out, "--out FILE") != NULL);
	run_free(&r);
}

static void bad_command_lines_exit_2(void)
{
	static const struct {
		const char *args[8];
		const char *msg;
	} cases[] = {
	    {{NULL}, "which generator"},
	    {{"fig99", NULL}, "no generator called 'fig99'"},
	    {{"fig16", "comb", NULL}, "one generator only"},
	    {{"fig16", "--level", NULL}, "--level needs a value (L)"},
	    {{"fig16", "--level", "7", NULL},
	     "--level '7' is out of range (1..6)"},
	    {{"fig16", "--level", "two", NULL}, "--level 'two' is not a whole"},
	    {{"fig16", "--level", "-1", NULL}, "--level '-1' is not a whole"},
	    {{"fig16", "--count", "5", NULL}, "fig16: takes only"},
	    {{"fig18", "--kind", "cubes", NULL},
	     "'cubes' is not one of boxes, spheres"},
	    {{"fig18", "--blend", "soft", NULL},
	     "'soft' is not one of sharp, smooth"},
	    {{"fig18", "--count", "0", NULL}, "--count '0' is out of range"},
	    {{"fig18", "--count", "99999999999", NULL}, "--count"},
	    {{"random", "--seed", "18446744073709551616", NULL}, "--seed"},
	    {{"random", "--depth", "1", NULL}, "--depth"},
	    {{"gears", "--teeth", "3", NULL}, "--teeth"},
	    {{"gears", "--frobnicate", NULL}, "unknown option"},
	    {{"gears", "--out", "", NULL}, "--out"},
	    {{"many-gears", "--count", "2000000", NULL}, "many-gears"},
	};
	for (size_t i = 0; i < sizeof(cases) / sizeof(cases[0]); i++) {
		struct run r = run_gen(cases[i].args);
		bool ok = r.status == 2 && r.err &&
		          strstr(r.err, cases[i].msg) != NULL && r.out &&
		          r.out[0] == '\0';
		if (!ok) {
			fprintf(stderr,
			        "  case %zu: status %d, stderr \"%s\"\n", i,
			        r.status, r.err ? r.err : "");
		}
		CHECK(ok);
		run_free(&r);
	}
}

static const struct bc_test tests[] = {
    {"prints_the_generators_scene", prints_the_generators_scene},
    {"writes_the_scene_with_out", writes_the_scene_with_out},
    {"help_lists_every_generator", help_lists_every_generator},
    {"bad_command_lines_exit_2", bad_command_lines_exit_2},
};

BC_TEST_MAIN(tests)
