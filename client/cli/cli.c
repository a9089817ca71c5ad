/*
 * What every `blobcast` command shares (cli.h): the one table from a
 * failure to an exit status, the hint that says what to do after it, and
 * "did you mean" for a mistyped command, option, key or kind, from one
 * edit distance. Kept apart from main.c, which parses the global options
 * and dispatches.
 */
#include "cli.h"

#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>

#include "blobcast/args.h"
#include "blobcast/blobtree.h"
#include "blobcast/error.h"
#include "blobcast/proto_fields.h"

int bc_cli_exit_for(int code, enum bc_cli_stage stage, bool broken)
{
	switch (code) {
	case 0:
		return BC_CLI_EXIT_OK;
	case BC_EAUTH:
	case BC_EPERM:
		return BC_CLI_EXIT_AUTH;
	case BC_EIO:
	case BC_ETIMEOUT:
	case BC_ECLOSED:
	case BC_EPROTO_MAGIC:
		return BC_CLI_EXIT_NETWORK;
	case BC_EPROTO_VERSION:
	case BC_ELIMIT:
	case BC_EBUSY:
		/* Answers of a blobcastd: a version it does not speak, a
		 * limit reached, busy. */
		return BC_CLI_EXIT_REFUSED;
	case BC_EINVAL:
		/* Before HELLO: our own options (a --ca file that does not
		 * load, a name). */
		return stage == BC_CLI_STAGE_CONNECT ? BC_CLI_EXIT_USAGE
		                                     : BC_CLI_EXIT_REFUSED;
	default:
		/* While connecting, the rest are the stream's (a truncated
		 * or malformed answer, a failed WebSocket upgrade) or the
		 * TLS port's ENOTSUP to plain bytes; later, a stream that
		 * broke is the network's, an ERROR answer the server's. */
		return stage == BC_CLI_STAGE_CONNECT || broken
		           ? BC_CLI_EXIT_NETWORK
		           : BC_CLI_EXIT_REFUSED;
	}
}

const char *bc_cli_hint(int code, enum bc_cli_stage stage, const char *msg)
{
	switch (code) {
	case BC_EAUTH:
		/* libblobcast's own words for a certificate say what to do
		 * (--ca FILE); the server's refusal of a token does not. */
		if (strncmp(msg, "TLS", 3) == 0) {
			return NULL;
		}
		return "give the token the server expects: --token TOKEN or "
		       "$BLOBCAST_TOKEN";
	case BC_EPERM:
		return "this needs the editor role: use a token that grants "
		       "it (--token TOKEN)";
	case BC_ENOSESSION:
		return "'blobcast sessions' lists the sessions; 'blobcast "
		       "load' creates one";
	case BC_ENONODE:
		return "'blobcast nodes --session NAME' lists the node ids";
	case BC_ETIMEOUT:
		return "the server did not answer in time: --timeout MS waits "
		       "longer (0: forever)";
	case BC_ECLOSED:
		return stage == BC_CLI_STAGE_CONNECT
		           ? NULL
		           : "the connection was lost (a daemon restart?): run "
		             "the command again";
	case BC_EPROTO_VERSION:
		return "the daemon speaks another protocol version: use a "
		       "client of its release";
	case BC_EBUSY:
		return "the server is busy: try again in a moment";
	case BC_ELIMIT:
		return "a limit of the server was reached (see above): ask "
		       "less, or ask its operator";
	default:
		return NULL;
	}
}

size_t bc_cli_distance(const char *a, const char *b)
{
	size_t n = strlen(a), m = strlen(b);
	/* Three rows of the dynamic programme: i-2, i-1 and i. */
	size_t row[3][BC_CLI_MAX_WORD + 1];
	if (n > BC_CLI_MAX_WORD || m > BC_CLI_MAX_WORD) {
		return SIZE_MAX;
	}
	for (size_t j = 0; j <= m; j++) {
		row[0][j] = j;
	}
	for (size_t i = 1; i <= n; i++) {
		size_t *cur = row[i % 3], *prev = row[(i + 2) % 3],
		       *prev2 = row[(i + 1) % 3];
		cur[0] = i;
		for (size_t j = 1; j <= m; j++) {
			size_t cost = a[i - 1] == b[j - 1] ? 0 : 1;
			size_t d = prev[j] + 1;
			if (cur[j - 1] + 1 < d) {
				d = cur[j - 1] + 1;
			}
			if (prev[j - 1] + cost < d) {
				d = prev[j - 1] + cost;
			}
			if (i > 1 && j > 1 && a[i - 1] == b[j - 2] &&
			    a[i - 2] == b[j - 1] && prev2[j - 2] + 1 < d) {
				d = prev2[j - 2] + 1;
			}
			cur[j] = d;
		}
	}
	return row[n % 3][m];
}

bool bc_cli_did_you_mean(const char *word, const char *const *candidates,
                         size_t n, const char *prefix, char *buf, size_t cap)
{
	size_t len = strlen(word), best = SIZE_MAX, nbest = 0, used;
	size_t limit = len <= 4 ? 1 : len <= 8 ? 2 : 3;
	const char *prefixed = NULL;
	size_t nprefixed = 0;
	buf[0] = '\0';
	for (size_t i = 0; i < n; i++) {
		size_t d;
		if (!candidates[i] || strcmp(candidates[i], word) == 0) {
			continue;
		}
		d = bc_cli_distance(word, candidates[i]);
		/* Not as many edits as the candidate has letters: "ab"
		 * is not a typo of "x". */
		if (d <= limit && d < strlen(candidates[i]) && d < best) {
			best = d;
		}
		if (len >= 3 && strncmp(candidates[i], word, len) == 0) {
			prefixed = candidates[i];
			nprefixed++;
		}
	}
	if (best == SIZE_MAX && nprefixed != 1) {
		return false;
	}
	used = (size_t)snprintf(buf, cap, " (did you mean ");
	/* Three at most: more is no suggestion. */
	for (size_t i = 0; i < n && used < cap && nbest < 3; i++) {
		bool pick =
		    candidates[i] && strcmp(candidates[i], word) != 0 &&
		    (best == SIZE_MAX
		         ? candidates[i] == prefixed
		         : bc_cli_distance(word, candidates[i]) == best);
		if (!pick) {
			continue;
		}
		used += (size_t)snprintf(buf + used, cap - used, "%s'%s%s'",
		                         nbest ? " or " : "", prefix,
		                         candidates[i]);
		nbest++;
	}
	if (used < cap) {
		snprintf(buf + used, cap - used, "?)");
	}
	return true;
}

/* Refuses the unknown option arg of a's table with the closest ones it
 * lists in its help. Returns 1 with a->status 2. */
static int unknown_option(struct bc_args *a, const char *arg)
{
	const char *names[BC_ARGS_MAX_OPTS + 1];
	char word[BC_CLI_MAX_WORD + 1], hint[160];
	const char *eq = strchr(arg, '=');
	size_t len = eq ? (size_t)(eq - arg) : strlen(arg), n = 0;
	for (int i = 0; a->opts && a->opts[i].kind != BC_OPT_INVALID &&
	                n < BC_ARGS_MAX_OPTS;
	     i++) {
		if (!(a->opts[i].flags & BC_OPT_HIDDEN)) {
			names[n++] = a->opts[i].name;
		}
	}
	names[n++] = "help";
	hint[0] = '\0';
	if (arg[1] == '-' && len - 2 <= BC_CLI_MAX_WORD) {
		memcpy(word, arg + 2, len - 2);
		word[len - 2] = '\0';
		bc_cli_did_you_mean(word, names, n, "--", hint, sizeof(hint));
	}
	a->status =
	    bc_args_error(a, "unknown option '%.*s'%s", (int)len, arg, hint);
	return 1;
}

int bc_cli_args_parse(struct bc_args *a, int argc, char **argv)
{
	for (int i = 1; i < argc; i++) {
		const char *arg = argv[i];
		const struct bc_opt *o;
		if (arg[0] != '-' || arg[1] == '\0') {
			if (a->stop_at_positional) {
				break;
			}
			continue;
		}
		if (strcmp(arg, "--") == 0 || strcmp(arg, "-h") == 0 ||
		    strcmp(arg, "--help") == 0) {
			/* The rest is positional, or the help wins. */
			break;
		}
		const char *val;
		int index;
		if (!(o = bc_args_find(a->opts, arg, &val, &index))) {
			return unknown_option(a, arg);
		}
		if (o->kind != BC_OPT_FLAG && !val) {
			i++; /* its value, whatever it looks like */
		}
	}
	return bc_args_parse(a, argc, argv);
}

/* Copies the word between the double quotes that follow the first
 * occurrence of lead in msg into word; false when there is none. */
static bool quoted_after(const char *msg, const char *lead, char *word,
                         size_t cap)
{
	const char *p = strstr(msg, lead), *end;
	if (!p) {
		return false;
	}
	p += strlen(lead);
	if (!(end = strchr(p, '"')) || (size_t)(end - p) >= cap) {
		return false;
	}
	memcpy(word, p, (size_t)(end - p));
	word[end - p] = '\0';
	return true;
}

/* Every primitive kind's name, then every operator's; returns the count. */
static size_t kind_names(const char **names, size_t cap)
{
	size_t n = 0;
	for (int k = 1; k < BC_PRIM_COUNT && n < cap; k++) {
		const struct bc_prim_info *info = bc_prim_info((enum bc_prim)k);
		if (info) {
			names[n++] = info->name;
		}
	}
	for (int k = 1; k < BC_OP_COUNT && n < cap; k++) {
		const char *name = bc_op_name((enum bc_op)k);
		if (name) {
			names[n++] = name;
		}
	}
	return n;
}

/* The scene file members of proto_fields.h's table with a fixed name that
 * apply to nodes `on` (translate rotate color; blend range), into keys;
 * returns how many (at most 3). */
static size_t named_scene_keys(unsigned on, const char **keys)
{
	size_t n = 0;
#define SCENE_KEY(name, k, lo, hi, numbers, flags)                             \
	if ((k) != NULL && (on & (flags)) && (BC_PROTO_IN_SCENE & (flags))) {  \
		keys[n++] = (k);                                               \
	}
	BC_PROTO_FIELDS(SCENE_KEY)
#undef SCENE_KEY
	return n;
}

/* The keys a scene file's node of kind what ("sphere", "smooth_union",
 * "twist") takes, as blobtree's JSON reader lists them; returns the count
 * (0 for an unknown kind). */
static size_t scene_keys(const char *what, const char **keys, size_t cap)
{
	enum bc_prim pk = bc_prim_from_name(what);
	enum bc_op op = bc_op_from_name(what);
	size_t n = 0;
	if (cap < 5 + BC_PRIM_MAX_PARAMS) {
		return 0;
	}
	keys[n++] = "type";
	keys[n++] = "id";
	if (pk != BC_PRIM_INVALID) {
		const struct bc_prim_info *info = bc_prim_info(pk);
		n += named_scene_keys(BC_PROTO_ON_PRIM, keys + n);
		for (uint32_t i = 0; info && i < info->nparams; i++) {
			keys[n++] = info->params[i].name;
		}
		return n;
	}
	if (op == BC_OP_INVALID) {
		return 0;
	}
	keys[n++] = "children";
	if (op == BC_OP_REPEAT) {
		keys[n++] = "spacing";
		keys[n++] = "count";
	} else if (bc_op_is_unary(op)) {
		keys[n++] = bc_unary_info(op)->param;
	} else if (bc_op_is_smooth(op)) {
		n += named_scene_keys(BC_PROTO_ON_OP, keys + n);
	}
	return n;
}

/* Prints names[0..n) on out as "PROG: LABEL: a, b, c", wrapped. */
static void print_list(FILE *out, const char *prog, const char *label,
                       const char *const *names, size_t n)
{
	size_t col = (size_t)fprintf(out, "%s: %s:", prog, label);
	for (size_t i = 0; i < n; i++) {
		size_t w = strlen(names[i]) + 2;
		if (col + w > 78) {
			col = (size_t)fprintf(out, "\n   ");
		}
		col += (size_t)fprintf(out, " %s%s", names[i],
		                       i + 1 < n ? "," : "");
	}
	fputc('\n', out);
}

/* Copies the name (letters, digits, '_') at the start of s into buf. */
static void name_at(const char *s, char *buf, size_t cap)
{
	size_t n = 0;
	while (n + 1 < cap && ((s[n] >= 'a' && s[n] <= 'z') ||
	                       (s[n] >= '0' && s[n] <= '9') || s[n] == '_')) {
		buf[n] = s[n];
		n++;
	}
	buf[n] = '\0';
}

void bc_cli_explain(FILE *out, const char *prog, const char *msg)
{
	const char *names[BC_PRIM_COUNT + BC_OP_COUNT + 8];
	const size_t cap = sizeof(names) / sizeof(names[0]);
	char word[BC_CLI_MAX_WORD + 1], what[BC_CLI_MAX_WORD + 1];
	char hint[200] = "", list[512];
	const char *keys, *p;
	size_t n = 0, nprims = 0;
	bool kinds = false;
	if (quoted_after(msg, "unknown primitive type \"", word,
	                 sizeof(word)) ||
	    quoted_after(msg, "unknown operator type \"", word, sizeof(word))) {
		/* A scene file's "type": any kind. */
		n = kind_names(names, cap);
		while (nprims < n &&
		       bc_prim_from_name(names[nprims]) != BC_PRIM_INVALID) {
			nprims++;
		}
		kinds = true;
	} else if (quoted_after(msg, "kind: \"", word, sizeof(word))) {
		/* An edit's kind=: operators and unary nodes (the message
		 * lists them). */
		size_t all = kind_names(names, cap);
		while (nprims < all &&
		       bc_prim_from_name(names[nprims]) != BC_PRIM_INVALID) {
			nprims++;
		}
		memmove(names, names + nprims,
		        (all - nprims) * sizeof(names[0]));
		n = all - nprims;
	} else if (quoted_after(msg, "unknown key \"", word, sizeof(word)) &&
	           (p = strstr(msg, "\" for "))) {
		/* A scene file's key: "... for sphere". */
		name_at(p + strlen("\" for "), what, sizeof(what));
		n = scene_keys(what, names, cap);
	} else if (quoted_after(msg, " has no \"", word, sizeof(word)) &&
	           (keys = strstr(msg, "; keys: "))) {
		/* An edit's key: the message lists those the node takes. */
		char *save = NULL, *tok;
		snprintf(list, sizeof(list), "%s", keys + strlen("; keys: "));
		for (tok = strtok_r(list, " ", &save); tok && n < cap;
		     tok = strtok_r(NULL, " ", &save)) {
			names[n++] = tok;
		}
	}
	if (n) {
		bc_cli_did_you_mean(word, names, n, "", hint, sizeof(hint));
	}
	fprintf(out, "%s: %s%s\n", prog, msg, hint);
	if (kinds) {
		print_list(out, prog, "primitive kinds", names, nprims);
		print_list(out, prog, "operator kinds", names + nprims,
		           n - nprims);
	}
}
