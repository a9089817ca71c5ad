/*
 * One table-driven command-line parser for every program (the blobcast
 * subcommands, blobcastd, the viewer). A command describes its options
 * once, in a table; the same table parses argv, checks each value with the
 * rules of blobcast/num.h and prints --help, so the help cannot list an
 * option the parser does not take, or a range it does not check.
 *
 * Syntax: `--name VALUE`, `--name=VALUE`, `-n VALUE` or `-nVALUE` for an
 * option with a short name; flags take no value (`--flag=x` is refused);
 * options and positional arguments mix in any order; `--` ends the
 * options (everything after it is positional); `-` alone is positional
 * (stdin, by convention). A repeated option keeps its last value.
 * `-h` and `--help` print the help on stdout and end parsing.
 *
 * Errors print "PROG: SENTENCE" and "(see 'PROG --help')" on stderr, the
 * same wording for every program, and the exit status is 2.
 */
#ifndef BLOBCAST_ARGS_H
#define BLOBCAST_ARGS_H

#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>

enum bc_opt_kind {
	BC_OPT_INVALID = 0, /* ends a table */
	BC_OPT_FLAG,        /* bool *: set to true */
	BC_OPT_U32,         /* uint32_t *, in [lo, hi] */
	BC_OPT_U64,         /* uint64_t *, in [lo, hi] */
	BC_OPT_F32,         /* float *, finite, in [lo, hi] */
	BC_OPT_STRING,      /* const char **: points into argv; never empty */
	BC_OPT_SIZE,        /* uint32_t[2]: "WxH", each in [lo, hi] */
	BC_OPT_VEC3,        /* float[3]: "x,y,z", each finite */
	BC_OPT_ENUM,        /* int *: the value of the name given (names) */
	BC_OPT_KIND_COUNT
};

/* One accepted word of an ENUM option; a table ends with a NULL name. */
struct bc_opt_name {
	const char *name;
	int value;
};

/* Flags of an option. */
#define BC_OPT_REQUIRED 1u /* bc_args_parse fails when it is missing */
#define BC_OPT_EMPTY 2u    /* a STRING may be "" */
/* Left out of the help: an option of a shared table that this command does
 * not take (the caller refuses it from seen). */
#define BC_OPT_HIDDEN 4u

/* One option. name is the long name without "--"; short_name 0 for none.
 * lo and hi bound numbers (both 0: the type's whole range; for U64 a hi of
 * 2^64 or more means UINT64_MAX). arg names the value in the help ("N",
 * "WxH"). help is the description, lines split by '\n'; in it "{range}" is
 * replaced by "lo..hi", "{choices}" by the ENUM names joined by " | " and
 * "{default}" by the value dst holds when the help is printed (commands set
 * their defaults before parsing), so the help says what the parser does. */
struct bc_opt {
	const char *name;
	char short_name;
	enum bc_opt_kind kind;
	void *dst;
	double lo, hi;
	const char *arg;
	const char *help;
	const struct bc_opt_name *names;
	unsigned flags;
};

/* Most options a table may have (seen is a 64-bit mask). */
#define BC_ARGS_MAX_OPTS 64

/* A command's description and, after bc_args_parse, its result. */
struct bc_args {
	/* In. prog prefixes every message ("blobcast render"). usage is the
	 * first help line(s) without the "usage: " word, about a paragraph
	 * after them, footer the text after the option list; each may hold
	 * several lines and about/footer may be NULL. opts ends with an
	 * entry of kind BC_OPT_INVALID. */
	const char *prog;
	const char *usage;
	const char *about;
	const char *footer;
	const struct bc_opt *opts;
	/* Parse options only up to the first positional argument, which
	 * with everything after it lands in pos unparsed: for a program
	 * whose options precede a command word with options of its own. */
	bool stop_at_positional;
	/* Called at the end of the help, for text only the program can
	 * produce (another table's commands); may be NULL. */
	void (*more_help)(FILE *out);
	/* Out. pos[0..npos) are the positional arguments in order (they
	 * point into argv, which bc_args_parse reorders). seen has bit i set
	 * when opts[i] was given. status is the exit status to return when
	 * bc_args_parse returns non-zero: 0 after --help, 2 after an error. */
	char **pos;
	int npos;
	uint64_t seen;
	int status;
};

/* Parses argv[1..argc) into the table's destinations (argv[0], the
 * command's name, is skipped). Returns 0 to go on, or 1 when the program
 * should exit with a->status: the help was printed (status 0) or an error
 * was (status 2). Destinations of options not given are left alone, so
 * callers set defaults before parsing. */
int bc_args_parse(struct bc_args *a, int argc, char **argv);

/* The option of table opts that arg ("--name", "--name=v", "-n", "-nv")
 * names, or NULL; *val is the value attached to arg (or NULL), *index the
 * option's place in opts. */
const struct bc_opt *bc_args_find(const struct bc_opt *opts, const char *arg,
                                  const char **val, int *index);

/* Sets o's destination from the text val under o's own rules (its range,
 * its choices), as the parser does for "--name val": for a program that
 * reads the same settings from elsewhere (a configuration file). Returns
 * 0, BC_EINVAL (val is not that kind of value) or BC_ERANGE (out of
 * range, not one of the choices); dst is left alone on a refusal. */
int bc_opt_set(const struct bc_opt *o, const char *val);

/* Writes a numeric option's range ("1..8192", "any" for other kinds) into
 * buf, as "{range}" in the help. */
void bc_opt_range_text(const struct bc_opt *o, char *buf, size_t cap);

/* Writes an ENUM's names joined by sep into buf. */
void bc_opt_choices_text(const struct bc_opt *o, const char *sep, char *buf,
                         size_t cap);

/* Whether the option with this long name was given. */
bool bc_args_given(const struct bc_args *a, const char *name);

/* Prints the help generated from the table: "usage: " usage, about, the
 * options (with -h, --help), footer. */
void bc_args_help(const struct bc_args *a, FILE *out);

/* Prints "PROG: MESSAGE" and the "see --help" line on stderr and returns 2,
 * for the checks a command does after parsing (required combinations,
 * values that depend on each other), so they read like the parser's. */
int bc_args_error(const struct bc_args *a, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 2, 3)))
#endif
    ;

#endif
