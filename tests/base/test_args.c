/* Tests of the number rules (num.h) and the table-driven argument parser
 * (args.h): every kind of option, both value spellings, the errors and
 * their wording, and a help text that lists exactly what is parsed. */
#include <float.h>
#include <stdint.h>
#include <stdio.h>
#include <unistd.h>

#include "blobcast/args.h"
#include "blobcast/error.h"
#include "blobcast/num.h"
#include "test.h"

static void num_integers_are_plain_decimal(void)
{
	uint32_t u = 7;
	uint64_t v = 7;
	CHECK_EQ_INT(bc_num_u32("0", 0, 10, &u), 0);
	CHECK_EQ_INT(u, 0);
	CHECK_EQ_INT(bc_num_u32("4294967295", 0, UINT32_MAX, &u), 0);
	CHECK(u == UINT32_MAX);
	CHECK_EQ_INT(bc_num_u32("4294967296", 0, UINT32_MAX, &u), BC_ERANGE);
	CHECK_EQ_INT(bc_num_u64("18446744073709551615", 0, UINT64_MAX, &v), 0);
	CHECK(v == UINT64_MAX);
	CHECK_EQ_INT(bc_num_u64("18446744073709551616", 0, UINT64_MAX, &v),
	             BC_ERANGE);
	CHECK_EQ_INT(bc_num_u32("11", 1, 10, &u), BC_ERANGE);
	CHECK_EQ_INT(bc_num_u32("0", 1, 10, &u), BC_ERANGE);
	/* What strtoul would take but a person does not mean. */
	const char *bad[] = {"",     " 1",  "1 ",  "+1", "-1",
	                     "0x10", "1e3", "1.0", "١",  "12a"};
	for (size_t i = 0; i < sizeof(bad) / sizeof(bad[0]); i++) {
		u = 99;
		CHECK_EQ_INT(bc_num_u32(bad[i], 0, UINT32_MAX, &u), BC_EINVAL);
		CHECK_EQ_INT(u, 99);
	}
	CHECK_EQ_INT(bc_num_u32(NULL, 0, 1, &u), BC_EINVAL);
}

static void num_floats_are_finite_decimal(void)
{
	float f = 0;
	double d = 0;
	CHECK_EQ_INT(bc_num_f32("-1.5e2", -1000, 1000, &f), 0);
	CHECK(f == -150.0f);
	CHECK_EQ_INT(bc_num_f32(".5", 0, 1, &f), 0);
	CHECK(f == 0.5f);
	CHECK_EQ_INT(bc_num_f32("5.", 0, 10, &f), 0);
	CHECK(f == 5.0f);
	CHECK_EQ_INT(bc_num_f32("180", 1, 179, &f), BC_ERANGE);
	/* Finite as a double but not as a float. */
	CHECK_EQ_INT(bc_num_f32("1e39", -INFINITY, INFINITY, &f), BC_ERANGE);
	CHECK_EQ_INT(bc_num_f64("1e400", -INFINITY, INFINITY, &d), BC_ERANGE);
	const char *bad[] = {"",  "nan", "inf", "-inf", "0x1p3", " 1", "1 ",
	                     ".", "e5",  "1e",  "1e+",  "--1",   "1,5"};
	for (size_t i = 0; i < sizeof(bad) / sizeof(bad[0]); i++) {
		CHECK_EQ_INT(bc_num_f32(bad[i], -INFINITY, INFINITY, &f),
		             BC_EINVAL);
	}
}

static void num_sizes_and_vectors(void)
{
	uint32_t w = 0, h = 0;
	float v[3] = {9, 9, 9};
	CHECK_EQ_INT(bc_num_size("640x480", 1, 8192, &w, &h), 0);
	CHECK(w == 640 && h == 480);
	CHECK_EQ_INT(bc_num_size("0x10", 1, 8192, &w, &h), BC_ERANGE);
	CHECK_EQ_INT(bc_num_size("10x99999", 1, 8192, &w, &h), BC_ERANGE);
	CHECK(w == 640 && h == 480);
	const char *bad[] = {"10",   "x10", "10x",   "10x10x10",
	                     "-1x5", "ax5", "10X10", "1 x1"};
	for (size_t i = 0; i < sizeof(bad) / sizeof(bad[0]); i++) {
		CHECK_EQ_INT(bc_num_size(bad[i], 1, 8192, &w, &h), BC_EINVAL);
	}
	CHECK_EQ_INT(bc_num_vec3("1,-2.5,3e1", v), 0);
	CHECK(v[0] == 1.0f && v[1] == -2.5f && v[2] == 30.0f);
	const char *badv[] = {"1,2",  "1,2,3,4", "nan,0,0", ",1,2",
	                      "1,,2", "1,2,",    "",        "1;2;3"};
	for (size_t i = 0; i < sizeof(badv) / sizeof(badv[0]); i++) {
		CHECK(bc_num_vec3(badv[i], v) != 0);
	}
	CHECK(v[0] == 1.0f && v[2] == 30.0f);
	float six[6];
	CHECK_EQ_INT(bc_num_f32s("0,1,2,3,4,5.5", six, 6), 0);
	CHECK(six[0] == 0.0f && six[5] == 5.5f);
	CHECK_EQ_INT(bc_num_f32s("0,1,2,3,4", six, 6), BC_EINVAL);
	CHECK_EQ_INT(bc_num_f32s("0,1,2,3,4,5,6", six, 6), BC_EINVAL);
	CHECK_EQ_INT(bc_num_f32s("1", six, 0), BC_EINVAL);
	CHECK_EQ_INT(bc_num_f32s("1", six, BC_NUM_MAX_FLOATS + 1), BC_EINVAL);
}

/* A command with one option of every kind. */
struct cmd {
	bool verbose;
	uint32_t threads;
	uint64_t seed;
	float fov;
	const char *out;
	uint32_t size[2];
	float eye[3];
	int mode;
};

static const struct bc_opt_name modes[] = {
    {"fast", 1}, {"exact", 2}, {NULL, 0}};

static void table(struct cmd *c, struct bc_opt opts[10])
{
	const struct bc_opt t[] = {
	    {.name = "verbose",
	     .short_name = 'v',
	     .kind = BC_OPT_FLAG,
	     .dst = &c->verbose,
	     .help = "say more"},
	    {.name = "threads",
	     .short_name = 'j',
	     .kind = BC_OPT_U32,
	     .dst = &c->threads,
	     .hi = 64,
	     .arg = "N",
	     .help = "threads, {range}"},
	    {.name = "seed",
	     .kind = BC_OPT_U64,
	     .dst = &c->seed,
	     .arg = "S",
	     .help = "random seed"},
	    {.name = "fov",
	     .kind = BC_OPT_F32,
	     .dst = &c->fov,
	     .lo = 1,
	     .hi = 179,
	     .arg = "DEG",
	     .help = "field of view,\ndegrees {range}"},
	    {.name = "out",
	     .short_name = 'o',
	     .kind = BC_OPT_STRING,
	     .dst = &c->out,
	     .arg = "FILE",
	     .help = "where to write",
	     .flags = BC_OPT_REQUIRED},
	    {.name = "size",
	     .kind = BC_OPT_SIZE,
	     .dst = c->size,
	     .lo = 1,
	     .hi = 8192,
	     .arg = "WxH",
	     .help = "frame size, each {range}"},
	    {.name = "eye",
	     .kind = BC_OPT_VEC3,
	     .dst = c->eye,
	     .arg = "X,Y,Z",
	     .help = "camera position"},
	    {.name = "mode",
	     .short_name = 'm',
	     .kind = BC_OPT_ENUM,
	     .dst = &c->mode,
	     .arg = "MODE",
	     .help = "{choices}",
	     .names = modes},
	    {.name = "a-rather-long-option-name",
	     .kind = BC_OPT_FLAG,
	     .help = "no dst: only seen"},
	    {.kind = BC_OPT_INVALID},
	};
	memcpy(opts, t, sizeof(t));
}

/* Runs the parser on a NULL-terminated argument list (argv[0] "cmd") with
 * stderr captured into err; returns bc_args_parse's result. */
static int run(struct cmd *c, struct bc_args *a, struct bc_opt *opts, char *err,
               size_t cap, char **argv)
{
	int argc = 0, rc, saved;
	FILE *tmp = tmpfile();
	size_t n;
	*c = (struct cmd){.threads = 4};
	table(c, opts);
	*a = (struct bc_args){
	    .prog = "bc test", .usage = "bc test [options] X", .opts = opts};
	while (argv[argc]) {
		argc++;
	}
	fflush(stderr);
	saved = dup(2);
	dup2(fileno(tmp), 2);
	rc = bc_args_parse(a, argc, argv);
	fflush(stderr);
	dup2(saved, 2);
	close(saved);
	rewind(tmp);
	n = fread(err, 1, cap - 1, tmp);
	err[n] = '\0';
	fclose(tmp);
	return rc;
}

#define ARGV(...) ((char *[]){"cmd", __VA_ARGS__, NULL})

static void args_parse_every_kind_both_spellings(void)
{
	struct cmd c;
	struct bc_args a;
	struct bc_opt opts[10];
	char err[1024];
	int rc = run(&c, &a, opts, err, sizeof(err),
	             ARGV("-v", "--threads", "8", "--seed=18446744073709551615",
	                  "pos1", "--fov=45.5", "-o", "a.png", "--size",
	                  "64x32", "--eye=1,2,3", "-mexact", "pos2", "-",
	                  "--a-rather-long-option-name"));
	CHECK_EQ_INT(rc, 0);
	CHECK_STREQ(err, "");
	CHECK(c.verbose);
	CHECK_EQ_INT(c.threads, 8);
	CHECK(c.seed == UINT64_MAX);
	CHECK(c.fov == 45.5f);
	CHECK_STREQ(c.out, "a.png");
	CHECK(c.size[0] == 64 && c.size[1] == 32);
	CHECK(c.eye[0] == 1.0f && c.eye[2] == 3.0f);
	CHECK_EQ_INT(c.mode, 2);
	REQUIRE(a.npos == 3);
	CHECK_STREQ(a.pos[0], "pos1");
	CHECK_STREQ(a.pos[1], "pos2");
	CHECK_STREQ(a.pos[2], "-");
	CHECK(bc_args_given(&a, "a-rather-long-option-name"));
	CHECK(bc_args_given(&a, "eye"));
	/* A repeated option keeps its last value; -j with the value
	 * attached. */
	rc = run(&c, &a, opts, err, sizeof(err),
	         ARGV("-o", "x", "-j3", "--threads=5"));
	CHECK_EQ_INT(rc, 0);
	CHECK_EQ_INT(c.threads, 5);
	CHECK(!bc_args_given(&a, "eye"));
	CHECK_EQ_INT(a.npos, 0);
}

/* A program whose options precede a command word: parsing stops at the
 * first positional, and the command's own options stay unparsed. */
static void args_stop_at_the_command_word(void)
{
	struct cmd c;
	struct bc_args a;
	struct bc_opt opts[10];
	char *argv[] = {"cmd",       "-v",      "-o", "x", "render",
	                "--verbose", "--bogus", "--", "y", NULL};
	int argc = 9;
	c = (struct cmd){0};
	table(&c, opts);
	a = (struct bc_args){
	    .prog = "bc test", .opts = opts, .stop_at_positional = true};
	CHECK_EQ_INT(bc_args_parse(&a, argc, argv), 0);
	CHECK(c.verbose);
	CHECK_STREQ(c.out, "x");
	REQUIRE(a.npos == 5);
	CHECK_STREQ(a.pos[0], "render");
	CHECK_STREQ(a.pos[1], "--verbose");
	CHECK_STREQ(a.pos[2], "--bogus");
	CHECK_STREQ(a.pos[3], "--");
	CHECK_STREQ(a.pos[4], "y");
}

static void args_double_dash_ends_options(void)
{
	struct cmd c;
	struct bc_args a;
	struct bc_opt opts[10];
	char err[1024];
	int rc = run(&c, &a, opts, err, sizeof(err),
	             ARGV("-o", "x", "--", "--verbose", "-j", "--"));
	CHECK_EQ_INT(rc, 0);
	CHECK(!c.verbose);
	REQUIRE(a.npos == 3);
	CHECK_STREQ(a.pos[0], "--verbose");
	CHECK_STREQ(a.pos[1], "-j");
	CHECK_STREQ(a.pos[2], "--");
}

/* Each mistake gets its own sentence, prefixed with the program, and a
 * pointer to --help; status 2 and nothing else parsed after it. */
static void args_errors_are_named(void)
{
	static const struct {
		const char *args[4];
		const char *msg;
	} cases[] = {
	    {{"--bogus"}, "bc test: unknown option '--bogus'\n"},
	    {{"--bogus=3"}, "bc test: unknown option '--bogus'\n"},
	    {{"-x"}, "bc test: unknown option '-x'\n"},
	    {{"--threads"}, "bc test: --threads needs a value (N)\n"},
	    {{"-o"}, "bc test: --out needs a value (FILE)\n"},
	    {{"--verbose=1"}, "bc test: --verbose takes no value\n"},
	    {{"--threads", "-1"},
	     "bc test: --threads '-1' is not a whole decimal number\n"},
	    {{"--threads", "65"},
	     "bc test: --threads '65' is out of range (0..64)\n"},
	    {{"--seed", "1.5"},
	     "bc test: --seed '1.5' is not a whole decimal number\n"},
	    {{"--fov", "nan"},
	     "bc test: --fov 'nan' is not a finite decimal number\n"},
	    {{"--fov", "180"},
	     "bc test: --fov '180' is out of range (1..179)\n"},
	    {{"--size", "10"},
	     "bc test: --size '10' is not WxH (two whole numbers)\n"},
	    {{"--size", "0x10"},
	     "bc test: --size '0x10' is out of range "
	     "(width and height 1..8192)\n"},
	    {{"--eye", "1,2"},
	     "bc test: --eye '1,2' is not x,y,z (three "
	     "finite numbers)\n"},
	    {{"--mode", "slow"},
	     "bc test: --mode 'slow' is not one of fast, exact\n"},
	    {{"--out="}, "bc test: --out needs a non-empty value\n"},
	    {{"-v"}, "bc test: --out FILE is required\n"},
	};
	for (size_t i = 0; i < sizeof(cases) / sizeof(cases[0]); i++) {
		struct cmd c;
		struct bc_args a;
		struct bc_opt opts[10];
		char err[1024], want[512];
		char *argv[6] = {"cmd"};
		for (int k = 0; k < 4 && cases[i].args[k]; k++) {
			argv[k + 1] = (char *)cases[i].args[k];
		}
		CHECK_EQ_INT(run(&c, &a, opts, err, sizeof(err), argv), 1);
		CHECK_EQ_INT(a.status, 2);
		snprintf(want, sizeof(want), "%s(see 'bc test --help')\n",
		         cases[i].msg);
		CHECK_STREQ(err, want);
	}
}

/* The help lists every option of the table with its value name and the
 * range the parser checks, and the parser stops after printing it. */
static void args_help_comes_from_the_table(void)
{
	struct cmd c;
	struct bc_opt opts[10];
	char text[4096];
	size_t n;
	FILE *f = tmpfile();
	table(&c, opts);
	struct bc_args a = {.prog = "bc test",
	                    .usage = "bc test X\nbc test Y",
	                    .about = "Does things.",
	                    .footer = "Exit 0.",
	                    .opts = opts};
	REQUIRE(f);
	bc_args_help(&a, f);
	rewind(f);
	n = fread(text, 1, sizeof(text) - 1, f);
	text[n] = '\0';
	fclose(f);
	CHECK_STREQ(text, "usage: bc test X\n"
	                  "       bc test Y\n"
	                  "\n"
	                  "Does things.\n"
	                  "\n"
	                  "  -v, --verbose      say more\n"
	                  "  -j, --threads N    threads, 0..64\n"
	                  "  --seed S           random seed\n"
	                  "  --fov DEG          field of view,\n"
	                  "                     degrees 1..179\n"
	                  "  -o, --out FILE     where to write\n"
	                  "  --size WxH         frame size, each 1..8192\n"
	                  "  --eye X,Y,Z        camera position\n"
	                  "  -m, --mode MODE    fast | exact\n"
	                  "  --a-rather-long-option-name\n"
	                  "                     no dst: only seen\n"
	                  "  -h, --help         this help\n"
	                  "\n"
	                  "Exit 0.\n");
	/* Every option the help names is one the parser takes. */
	for (int i = 0; opts[i].kind != BC_OPT_INVALID; i++) {
		char needle[64];
		snprintf(needle, sizeof(needle), "--%s", opts[i].name);
		CHECK(strstr(text, needle) != NULL);
	}
}

/* "{default}" prints what the destination holds when the help is shown,
 * so a command that sets its defaults first documents them truly. */
static void args_help_shows_defaults(void)
{
	uint32_t n = 12;
	uint64_t big = 18446744073709551615ull;
	float f = 0.25f;
	int mode = 2;
	const char *name = NULL;
	char text[2048];
	size_t len;
	const struct bc_opt opts[] = {
	    {.name = "n",
	     .kind = BC_OPT_U32,
	     .dst = &n,
	     .arg = "N",
	     .help = "default {default}"},
	    {.name = "big",
	     .kind = BC_OPT_U64,
	     .dst = &big,
	     .arg = "B",
	     .help = "default {default}"},
	    {.name = "f",
	     .kind = BC_OPT_F32,
	     .dst = &f,
	     .arg = "F",
	     .help = "default {default}"},
	    {.name = "mode",
	     .kind = BC_OPT_ENUM,
	     .dst = &mode,
	     .arg = "M",
	     .help = "default {default}",
	     .names = modes},
	    {.name = "name",
	     .kind = BC_OPT_STRING,
	     .dst = &name,
	     .arg = "S",
	     .help = "default {default}"},
	    {.kind = BC_OPT_INVALID},
	};
	struct bc_args a = {.prog = "p", .opts = opts};
	FILE *tmp = tmpfile();
	REQUIRE(tmp);
	bc_args_help(&a, tmp);
	rewind(tmp);
	len = fread(text, 1, sizeof(text) - 1, tmp);
	text[len] = '\0';
	fclose(tmp);
	CHECK(strstr(text, "  --n N              default 12\n") != NULL);
	CHECK(strstr(text, "default 18446744073709551615\n") != NULL);
	CHECK(strstr(text, "  --f F              default 0.25\n") != NULL);
	CHECK(strstr(text, "  --mode M           default exact\n") != NULL);
	CHECK(strstr(text, "  --name S           default none\n") != NULL);
}

/* A hidden option is parsed (and marked seen) but left out of the help:
 * one table shared by commands that each take part of it. */
static void args_hidden_options_parse_but_stay_out_of_help(void)
{
	bool quiet = false;
	uint32_t n = 0;
	char text[1024];
	size_t len;
	char arg0[] = "p", arg1[] = "--quiet", arg2[] = "--n=3";
	char *argv[] = {arg0, arg1, arg2, NULL};
	struct bc_opt opts[] = {
	    {.name = "quiet",
	     .kind = BC_OPT_FLAG,
	     .dst = &quiet,
	     .help = "say less",
	     .flags = BC_OPT_HIDDEN},
	    {.name = "n",
	     .kind = BC_OPT_U32,
	     .dst = &n,
	     .arg = "N",
	     .help = "count"},
	    {.kind = BC_OPT_INVALID},
	};
	struct bc_args a = {.prog = "p", .opts = opts};
	FILE *tmp = tmpfile();
	REQUIRE(tmp);
	bc_args_help(&a, tmp);
	rewind(tmp);
	len = fread(text, 1, sizeof(text) - 1, tmp);
	text[len] = '\0';
	fclose(tmp);
	CHECK(strstr(text, "--quiet") == NULL);
	CHECK(strstr(text, "  --n N              count\n") != NULL);
	CHECK_EQ_INT(bc_args_parse(&a, 3, argv), 0);
	CHECK(quiet);
	CHECK_EQ_INT((int)n, 3);
	CHECK(bc_args_given(&a, "quiet"));
}

/* bc_opt_set: one option's value from text, as a configuration file gives
 * it, under the rules the parser applies; a refusal leaves dst alone. */
static void args_one_value_under_the_tables_rules(void)
{
	struct cmd c = {.threads = 4, .mode = 1};
	struct bc_opt opts[10];
	char buf[64];
	table(&c, opts);
	CHECK_EQ_INT(bc_opt_set(&opts[1], "64"), 0);
	CHECK_EQ_INT((int)c.threads, 64);
	CHECK_EQ_INT(bc_opt_set(&opts[1], "65"), BC_ERANGE);
	CHECK_EQ_INT(bc_opt_set(&opts[1], "-1"), BC_EINVAL);
	CHECK_EQ_INT(bc_opt_set(&opts[1], "8 "), BC_EINVAL);
	CHECK_EQ_INT((int)c.threads, 64);
	CHECK_EQ_INT(bc_opt_set(&opts[3], "180"), BC_ERANGE);
	CHECK_EQ_INT(bc_opt_set(&opts[5], "8193x1"), BC_ERANGE);
	CHECK_EQ_INT(bc_opt_set(&opts[5], "8x"), BC_EINVAL);
	CHECK_EQ_INT(bc_opt_set(&opts[4], ""), BC_EINVAL);
	CHECK_EQ_INT(bc_opt_set(&opts[7], "exact"), 0);
	CHECK_EQ_INT(c.mode, 2);
	CHECK_EQ_INT(bc_opt_set(&opts[7], "slow"), BC_ERANGE);
	CHECK_EQ_INT(c.mode, 2);
	bc_opt_range_text(&opts[1], buf, sizeof(buf));
	CHECK_STREQ(buf, "0..64");
	bc_opt_range_text(&opts[2], buf, sizeof(buf));
	CHECK_STREQ(buf, "0..18446744073709551615");
	bc_opt_choices_text(&opts[7], ", ", buf, sizeof(buf));
	CHECK_STREQ(buf, "fast, exact");
}

static const struct bc_test tests[] = {
    {"num_integers_are_plain_decimal", num_integers_are_plain_decimal},
    {"num_floats_are_finite_decimal", num_floats_are_finite_decimal},
    {"num_sizes_and_vectors", num_sizes_and_vectors},
    {"args_parse_every_kind_both_spellings",
     args_parse_every_kind_both_spellings},
    {"args_double_dash_ends_options", args_double_dash_ends_options},
    {"args_stop_at_the_command_word", args_stop_at_the_command_word},
    {"args_help_shows_defaults", args_help_shows_defaults},
    {"args_errors_are_named", args_errors_are_named},
    {"args_help_comes_from_the_table", args_help_comes_from_the_table},
    {"args_hidden_options_parse_but_stay_out_of_help",
     args_hidden_options_parse_but_stay_out_of_help},
    {"args_one_value_under_the_tables_rules",
     args_one_value_under_the_tables_rules},
};
BC_TEST_MAIN(tests)
