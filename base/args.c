/*
 * The table-driven argument parser (blobcast/args.h). Values are checked
 * with blobcast/num.h; every message goes through one function, so all
 * programs word their errors alike.
 */
#include "blobcast/args.h"

#include <assert.h>
#include <math.h>
#include <stdarg.h>
#include <string.h>

#include "blobcast/error.h"
#include "blobcast/num.h"

/* Help text: the option column is this wide (two spaces of indent
 * included); longer names put their description on the next line. */
#define HELP_COL 21

static int count_opts(const struct bc_opt *opts)
{
	int n = 0;
	while (opts && opts[n].kind != BC_OPT_INVALID) {
		n++;
	}
	/* A programmer error: the table is a constant of the program. */
	assert(n <= BC_ARGS_MAX_OPTS);
	return n;
}

/* fmt is the caller's format, checked at bc_args_error's own attribute. */
__attribute__((format(printf, 2, 0))) static void
verror(const struct bc_args *a, const char *fmt, va_list ap)
{
	fprintf(stderr, "%s: ", a->prog);
	vfprintf(stderr, fmt, ap);
	fprintf(stderr, "\n(see '%s --help')\n", a->prog);
}

int bc_args_error(const struct bc_args *a, const char *fmt, ...)
{
	va_list ap;
	va_start(ap, fmt);
	verror(a, fmt, ap);
	va_end(ap);
	return 2;
}

#if defined(__GNUC__)
__attribute__((format(printf, 2, 3)))
#endif
static int
fail(struct bc_args *a, const char *fmt, ...)
{
	va_list ap;
	va_start(ap, fmt);
	verror(a, fmt, ap);
	va_end(ap);
	a->status = 2;
	return 1;
}

/* The bounds of a numeric option, the type's own when lo == hi == 0. */
static void bounds_u64(const struct bc_opt *o, uint64_t max, uint64_t *lo,
                       uint64_t *hi)
{
	if (o->lo == 0.0 && o->hi == 0.0) {
		*lo = 0;
		*hi = max;
		return;
	}
	*lo = o->lo <= 0.0 ? 0 : (uint64_t)o->lo;
	/* 2^64 and up do not convert: they mean the type's maximum. */
	*hi = o->hi >= 18446744073709551615.0 || (uint64_t)o->hi > max
	          ? max
	          : (uint64_t)o->hi;
}

static void bounds_f32(const struct bc_opt *o, float *lo, float *hi)
{
	if (o->lo == 0.0 && o->hi == 0.0) {
		*lo = -INFINITY;
		*hi = INFINITY;
		return;
	}
	*lo = (float)o->lo;
	*hi = (float)o->hi;
}

void bc_opt_range_text(const struct bc_opt *o, char *buf, size_t cap)
{
	uint64_t lo, hi;
	float flo, fhi;
	switch (o->kind) {
	case BC_OPT_U32:
	case BC_OPT_SIZE:
		bounds_u64(o, UINT32_MAX, &lo, &hi);
		snprintf(buf, cap, "%llu..%llu", (unsigned long long)lo,
		         (unsigned long long)hi);
		break;
	case BC_OPT_U64:
		bounds_u64(o, UINT64_MAX, &lo, &hi);
		snprintf(buf, cap, "%llu..%llu", (unsigned long long)lo,
		         (unsigned long long)hi);
		break;
	case BC_OPT_F32:
		bounds_f32(o, &flo, &fhi);
		snprintf(buf, cap, "%g..%g", (double)flo, (double)fhi);
		break;
	default:
		snprintf(buf, cap, "any");
		break;
	}
}

void bc_opt_choices_text(const struct bc_opt *o, const char *sep, char *buf,
                         size_t cap)
{
	size_t len = 0;
	buf[0] = '\0';
	for (const struct bc_opt_name *n = o->names; n && n->name; n++) {
		int w = snprintf(buf + len, cap - len, "%s%s",
		                 n == o->names ? "" : sep, n->name);
		if (w < 0 || (size_t)w >= cap - len) {
			break;
		}
		len += (size_t)w;
	}
}

int bc_opt_set(const struct bc_opt *o, const char *val)
{
	uint64_t lo, hi, u64;
	uint32_t u32, wh[2];
	float flo, fhi, f, v[3];
	int rc;
	switch (o->kind) {
	case BC_OPT_U32:
		bounds_u64(o, UINT32_MAX, &lo, &hi);
		if ((rc = bc_num_u32(val, (uint32_t)lo, (uint32_t)hi, &u32)) ==
		    0) {
			*(uint32_t *)o->dst = u32;
		}
		return rc;
	case BC_OPT_U64:
		bounds_u64(o, UINT64_MAX, &lo, &hi);
		if ((rc = bc_num_u64(val, lo, hi, &u64)) == 0) {
			*(uint64_t *)o->dst = u64;
		}
		return rc;
	case BC_OPT_F32:
		bounds_f32(o, &flo, &fhi);
		if ((rc = bc_num_f32(val, flo, fhi, &f)) == 0) {
			*(float *)o->dst = f;
		}
		return rc;
	case BC_OPT_SIZE:
		bounds_u64(o, UINT32_MAX, &lo, &hi);
		rc = bc_num_size(val, (uint32_t)lo, (uint32_t)hi, &wh[0],
		                 &wh[1]);
		if (rc == 0) {
			memcpy(o->dst, wh, sizeof(wh));
		}
		return rc;
	case BC_OPT_VEC3:
		if (bc_num_vec3(val, v)) {
			return BC_EINVAL;
		}
		memcpy(o->dst, v, sizeof(v));
		return 0;
	case BC_OPT_STRING:
		if (!val[0] && !(o->flags & BC_OPT_EMPTY)) {
			return BC_EINVAL;
		}
		*(const char **)o->dst = val;
		return 0;
	case BC_OPT_ENUM:
		for (const struct bc_opt_name *n = o->names; n && n->name;
		     n++) {
			if (strcmp(n->name, val) == 0) {
				*(int *)o->dst = n->value;
				return 0;
			}
		}
		return BC_ERANGE;
	default:
		assert(0 && "option kind without a value");
		return BC_EINVAL;
	}
}

/* bc_opt_set, its refusal worded for the command line. */
static int set_value(struct bc_args *a, const struct bc_opt *o, const char *val)
{
	char range[96], choices[256];
	int rc = bc_opt_set(o, val);
	if (!rc) {
		return 0;
	}
	bc_opt_range_text(o, range, sizeof(range));
	switch (o->kind) {
	case BC_OPT_SIZE:
		return fail(a,
		            rc == BC_EINVAL
		                ? "--%s '%s' is not WxH (two whole "
		                  "numbers)"
		                : "--%s '%s' is out of range (width "
		                  "and height %s)",
		            o->name, val, range);
	case BC_OPT_VEC3:
		return fail(a, "--%s '%s' is not x,y,z (three finite numbers)",
		            o->name, val);
	case BC_OPT_STRING:
		return fail(a, "--%s needs a non-empty value", o->name);
	case BC_OPT_ENUM:
		bc_opt_choices_text(o, ", ", choices, sizeof(choices));
		return fail(a, "--%s '%s' is not one of %s", o->name, val,
		            choices);
	case BC_OPT_U32:
	case BC_OPT_U64:
	case BC_OPT_F32:
		break;
	default:
		return fail(a, "--%s: bad option table", o->name);
	}
	if (rc == BC_EINVAL) {
		return fail(a, "--%s '%s' is not %s", o->name, val,
		            o->kind == BC_OPT_F32 ? "a finite decimal number"
		                                  : "a whole decimal number");
	}
	return fail(a, "--%s '%s' is out of range (%s)", o->name, val, range);
}

const struct bc_opt *bc_args_find(const struct bc_opt *opts, const char *arg,
                                  const char **val, int *index)
{
	*val = NULL;
	for (int i = 0; opts && opts[i].kind != BC_OPT_INVALID; i++) {
		const struct bc_opt *o = &opts[i];
		if (arg[1] == '-') {
			const char *name = arg + 2, *eq = strchr(name, '=');
			size_t n = eq ? (size_t)(eq - name) : strlen(name);
			if (strlen(o->name) == n &&
			    strncmp(o->name, name, n) == 0) {
				*val = eq ? eq + 1 : NULL;
				*index = i;
				return o;
			}
		} else if (o->short_name && arg[1] == o->short_name) {
			*val = arg[2] ? arg + 2 : NULL;
			*index = i;
			return o;
		}
	}
	return NULL;
}

int bc_args_parse(struct bc_args *a, int argc, char **argv)
{
	int nopts = count_opts(a->opts);
	bool only_pos = false;
	a->pos = argv + 1;
	a->npos = 0;
	a->seen = 0;
	a->status = 0;
	for (int i = 1; i < argc; i++) {
		char *arg = argv[i];
		const struct bc_opt *o;
		const char *val;
		int index = 0;
		if (only_pos || arg[0] != '-' || arg[1] == '\0') {
			/* Slots 1..i are consumed: reorder in place. */
			argv[1 + a->npos++] = arg;
			if (a->stop_at_positional) {
				only_pos = true;
			}
			continue;
		}
		if (strcmp(arg, "--") == 0) {
			only_pos = true;
			continue;
		}
		if (strcmp(arg, "-h") == 0 || strcmp(arg, "--help") == 0) {
			bc_args_help(a, stdout);
			a->status = 0;
			return 1;
		}
		if (!(o = bc_args_find(a->opts, arg, &val, &index))) {
			const char *eq = strchr(arg, '=');
			int n = eq ? (int)(eq - arg) : (int)strlen(arg);
			return fail(a, "unknown option '%.*s'", n, arg);
		}
		a->seen |= (uint64_t)1 << index;
		if (o->kind == BC_OPT_FLAG) {
			if (val) {
				return fail(a, "--%s takes no value", o->name);
			}
			if (o->dst) {
				*(bool *)o->dst = true;
			}
			continue;
		}
		if (!val) {
			if (i + 1 >= argc) {
				return fail(a, "--%s needs a value (%s)",
				            o->name, o->arg ? o->arg : "VALUE");
			}
			val = argv[++i];
		}
		if (set_value(a, o, val)) {
			return 1;
		}
	}
	for (int i = 0; i < nopts; i++) {
		const struct bc_opt *o = &a->opts[i];
		if ((o->flags & BC_OPT_REQUIRED) &&
		    !(a->seen & ((uint64_t)1 << i))) {
			if (o->arg) {
				return fail(a, "--%s %s is required", o->name,
				            o->arg);
			}
			return fail(a, "--%s is required", o->name);
		}
	}
	return 0;
}

bool bc_args_given(const struct bc_args *a, const char *name)
{
	for (int i = 0; a->opts && a->opts[i].kind != BC_OPT_INVALID; i++) {
		if (strcmp(a->opts[i].name, name) == 0) {
			return (a->seen >> i) & 1u;
		}
	}
	return false;
}

/* Writes the value the option's destination holds now (the command's
 * default when help is printed before parsing) into buf. */
static void default_text(const struct bc_opt *o, char *buf, size_t cap)
{
	snprintf(buf, cap, "none");
	if (!o->dst) {
		return;
	}
	switch (o->kind) {
	case BC_OPT_U32:
		snprintf(buf, cap, "%u", (unsigned)*(const uint32_t *)o->dst);
		break;
	case BC_OPT_U64:
		snprintf(buf, cap, "%llu",
		         (unsigned long long)*(const uint64_t *)o->dst);
		break;
	case BC_OPT_F32:
		snprintf(buf, cap, "%g", (double)*(const float *)o->dst);
		break;
	case BC_OPT_STRING:
		if (*(const char *const *)o->dst) {
			snprintf(buf, cap, "%s", *(const char *const *)o->dst);
		}
		break;
	case BC_OPT_ENUM:
		for (const struct bc_opt_name *n = o->names; n && n->name;
		     n++) {
			if (n->value == *(const int *)o->dst) {
				snprintf(buf, cap, "%s", n->name);
				break;
			}
		}
		break;
	default:
		break;
	}
}

/* Prints text, each line after the first indented to indent columns, with
 * "{range}" and "{choices}" replaced for option o (NULL: no
 * replacement). */
static void print_text(FILE *out, const char *text, int indent,
                       const struct bc_opt *o)
{
	char buf[256];
	for (const char *p = text; *p; p++) {
		if (o && strncmp(p, "{range}", 7) == 0) {
			bc_opt_range_text(o, buf, sizeof(buf));
			fputs(buf, out);
			p += 6;
		} else if (o && strncmp(p, "{default}", 9) == 0) {
			default_text(o, buf, sizeof(buf));
			fputs(buf, out);
			p += 8;
		} else if (o && strncmp(p, "{choices}", 9) == 0) {
			bc_opt_choices_text(o, " | ", buf, sizeof(buf));
			fputs(buf, out);
			p += 8;
		} else if (*p == '\n') {
			fprintf(out, "\n%*s", p[1] ? indent : 0, "");
		} else {
			fputc(*p, out);
		}
	}
	fputc('\n', out);
}

static void print_opt(FILE *out, const struct bc_opt *o)
{
	char left[96], shrt[8] = "";
	bool arg = o->kind != BC_OPT_FLAG && o->arg;
	int n;
	if (o->short_name) {
		snprintf(shrt, sizeof(shrt), "-%c, ", o->short_name);
	}
	n = snprintf(left, sizeof(left), "  %s--%s%s%s", shrt, o->name,
	             arg ? " " : "", arg ? o->arg : "");
	if (n >= HELP_COL - 1) {
		fprintf(out, "%s\n%*s", left, HELP_COL, "");
	} else {
		fprintf(out, "%-*s", HELP_COL, left);
	}
	print_text(out, o->help ? o->help : "", HELP_COL, o);
}

void bc_args_help(const struct bc_args *a, FILE *out)
{
	fprintf(out, "usage: ");
	print_text(out, a->usage ? a->usage : a->prog, 7, NULL);
	if (a->about) {
		fputc('\n', out);
		print_text(out, a->about, 0, NULL);
	}
	fputc('\n', out);
	for (int i = 0; a->opts && a->opts[i].kind != BC_OPT_INVALID; i++) {
		if (!(a->opts[i].flags & BC_OPT_HIDDEN)) {
			print_opt(out, &a->opts[i]);
		}
	}
	print_opt(out, &(const struct bc_opt){.name = "help",
	                                      .short_name = 'h',
	                                      .kind = BC_OPT_FLAG,
	                                      .help = "this help"});
	if (a->footer) {
		fputc('\n', out);
		print_text(out, a->footer, 0, NULL);
	}
	if (a->more_help) {
		a->more_help(out);
	}
}
