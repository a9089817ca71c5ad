/*
 * blobcastd: options, configuration file, start-up and shutdown.
 *
 * With no arguments it serves the embedded default scene in session
 * "default" on 127.0.0.1:7878 with ./blobcast-data as its data directory.
 * SIGTERM or SIGINT saves every session and stops within
 * BC_SRV_STOP_MS whatever the load; SIGHUP re-reads the access tokens of
 * the --config file.
 *
 * main is where the layers meet (link.h): it makes them bottom up -- the
 * store, the work layer, the transport (whose link the others send
 * through), the sessions, dispatch -- and wires each one's callbacks.
 */
#include <signal.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <jansson.h>

#include "blobcast/alloc.h"
#include "blobcast/args.h"
#include "blobcast/log.h"
#include "config.h"
#include "dispatch.h"
#include "link.h"
#include "sessions.h"
#include "srv_limits.h"
#include "store.h"
#include "transport.h"
#include "vstream.h"
#include "work.h"

/* auto and cpu: on hosts without a GPU the CPU tile tracer beats llvmpipe
 * (docs/benchmarks.md); a GPU host asks for gl. */
static const struct bc_opt_name backend_names[] = {{"auto", BC_BACKEND_TILED},
                                                   {"cpu", BC_BACKEND_TILED},
                                                   {"tiled", BC_BACKEND_TILED},
                                                   {"naive", BC_BACKEND_NAIVE},
                                                   {"gl", BC_BACKEND_GL},
                                                   {"svo", BC_BACKEND_SVO},
                                                   {NULL, 0}};
static const struct bc_opt_name platform_names[] = {
    {"auto", 0}, {"device", 1}, {"surfaceless", 2}, {"osmesa", 3}, {NULL, 0}};
static const struct bc_opt_name simd_names[] = {
    {"auto", BC_SIMD_AUTO}, {"off", BC_SIMD_OFF}, {NULL, 0}};
/* H.264 views (encoding 4): which libavcodec encoder, and libx264's
 * preset (its speed against its bytes, docs/video.md). */
static const struct bc_opt_name video_names[] = {
    {"auto", BC_VIDEO_BACKEND_AUTO},
    {"x264", BC_VIDEO_BACKEND_X264},
    {"nvenc", BC_VIDEO_BACKEND_NVENC},
    {NULL, 0}};
static const struct bc_opt_name preset_names[] = {
    {"ultrafast", 1}, {"superfast", 2}, {"veryfast", 3}, {"faster", 4},
    {"fast", 5},      {"medium", 6},    {"slow", 7},     {"slower", 8},
    {"veryslow", 9},  {NULL, 0}};
static const struct bc_opt_name log_names[] = {
    {"silent", BC_LOG_SILENT}, {"error", BC_LOG_ERROR}, {"warn", BC_LOG_WARN},
    {"info", BC_LOG_INFO},     {"debug", BC_LOG_DEBUG}, {NULL, 0}};

/* The command line, before it is merged over the configuration file.
 * Strings point into argv; 0 and NULL mean "not given". */
struct cli {
	const char *listen, *unix_path, *data_dir, *config;
	const char *tls_cert, *tls_key, *server_id, *check;
	int backend, gl_platform, simd, log, video_encoder, x264_preset;
	bool allow_plaintext, tls_allow_expired, no_damage, no_pace, repair;
	uint32_t frame_budget_ms, render_threads, view_cache_mib, max_scene_mib;
	uint32_t client_queue_mib, render_idle_s, scene_memory_mib;
};

/* The option table over c; --help is printed from it. */
#define DAEMON_OPTS(c)                                                         \
	{                                                                      \
		{.name = "listen",                                             \
		 .kind = BC_OPT_STRING,                                        \
		 .dst = &(c)->listen,                                          \
		 .arg = "HOST:PORT",                                           \
		 .help = "TCP address (default 127.0.0.1:7878;\n"              \
		         "\"none\" for no TCP listener)"},                     \
		    {.name = "unix",                                           \
		     .kind = BC_OPT_STRING,                                    \
		     .dst = &(c)->unix_path,                                   \
		     .arg = "PATH",                                            \
		     .help = "also listen on a Unix socket"},                  \
		    {.name = "tls-cert",                                       \
		     .kind = BC_OPT_STRING,                                    \
		     .dst = &(c)->tls_cert,                                    \
		     .arg = "FILE",                                            \
		     .help = "TLS on the TCP listener: certificate\n"          \
		             "chain (PEM); clients use tls://HOST:PORT"},      \
		    {.name = "tls-key",                                        \
		     .kind = BC_OPT_STRING,                                    \
		     .dst = &(c)->tls_key,                                     \
		     .arg = "FILE",                                            \
		     .help = "its private key (PEM; default: the\n"            \
		             "--tls-cert file)"},                              \
		    {.name = "tls-allow-expired",                              \
		     .kind = BC_OPT_FLAG,                                      \
		     .dst = &(c)->tls_allow_expired,                           \
		     .help = "start even when the certificate has\n"           \
		             "expired or is not valid yet (refused\n"          \
		             "otherwise; a warning in the log)"},              \
		    {.name = "allow-plaintext",                                \
		     .kind = BC_OPT_FLAG,                                      \
		     .dst = &(c)->allow_plaintext,                             \
		     .help = "start with tokens on a plain TCP\n"              \
		             "listener reachable from other hosts\n"           \
		             "(refused otherwise)"},                           \
		    {.name = "data",                                           \
		     .kind = BC_OPT_STRING,                                    \
		     .dst = &(c)->data_dir,                                    \
		     .arg = "DIR",                                             \
		     .help = "data directory: sessions, journals\n"            \
		             "(default ./blobcast-data)"},                     \
		    {.name = "backend",                                        \
		     .kind = BC_OPT_ENUM,                                      \
		     .dst = &(c)->backend,                                     \
		     .arg = "NAME",                                            \
		     .help = "{choices}\n(auto and cpu: the CPU tile tracer)", \
		     .names = backend_names},                                  \
		    {.name = "gl-platform",                                    \
		     .kind = BC_OPT_ENUM,                                      \
		     .dst = &(c)->gl_platform,                                 \
		     .arg = "P",                                               \
		     .help = "{choices}",                                      \
		     .names = platform_names},                                 \
		    {.name = "simd",                                           \
		     .kind = BC_OPT_ENUM,                                      \
		     .dst = &(c)->simd,                                        \
		     .arg = "MODE",                                            \
		     .help = "{choices}: vector instructions of the\n"         \
		             "CPU tracers (default auto)",                     \
		     .names = simd_names},                                     \
		    {.name = "video-encoder",                                  \
		     .kind = BC_OPT_ENUM,                                      \
		     .dst = &(c)->video_encoder,                               \
		     .arg = "NAME",                                            \
		     .help = "{choices}: H.264 views' encoder\n"               \
		             "(default auto: h264_nvenc where it opens,\n"     \
		             "else libx264; nvenc alone fails over to\n"       \
		             "the client's image encodings)",                  \
		     .names = video_names},                                    \
		    {.name = "x264-preset",                                    \
		     .kind = BC_OPT_ENUM,                                      \
		     .dst = &(c)->x264_preset,                                 \
		     .arg = "NAME",                                            \
		     .help = "libx264's speed against its bytes\n"             \
		             "(default faster): {choices}",                    \
		     .names = preset_names},                                   \
		    {.name = "no-damage",                                      \
		     .kind = BC_OPT_FLAG,                                      \
		     .dst = &(c)->no_damage,                                   \
		     .help = "edits re-render whole views instead of\n"        \
		             "the tiles they change (to compare)"},            \
		    {.name = "no-pace",                                        \
		     .kind = BC_OPT_FLAG,                                      \
		     .dst = &(c)->no_pace,                                     \
		     .help = "write frames as fast as the kernel takes\n"      \
		             "them, not as the link carries them (to\n"        \
		             "compare)"},                                      \
		    {.name = "frame-budget",                                   \
		     .kind = BC_OPT_U32,                                       \
		     .dst = &(c)->frame_budget_ms,                             \
		     .lo = 1,                                                  \
		     .hi = 600000,                                             \
		     .arg = "MS",                                              \
		     .help = "time one refinement step may take,\n"            \
		             "{range} (default 2000); past it the\n"           \
		             "picture stays at its coarser level"},            \
		    {.name = "render-threads",                                 \
		     .kind = BC_OPT_U32,                                       \
		     .dst = &(c)->render_threads,                              \
		     .lo = 1,                                                  \
		     .hi = 64,                                                 \
		     .arg = "N",                                               \
		     .help = "render workers, {range} (default: one\n"         \
		             "per core); sessions share them fairly"},         \
		    {.name = "view-cache",                                     \
		     .kind = BC_OPT_U32,                                       \
		     .dst = &(c)->view_cache_mib,                              \
		     .lo = 16,                                                 \
		     .hi = 1048576,                                            \
		     .arg = "MIB",                                             \
		     .help = "memory for kept views and renderer\n"            \
		             "state, {range} (default 384)"},                  \
		    {.name = "max-scene",                                      \
		     .kind = BC_OPT_U32,                                       \
		     .dst = &(c)->max_scene_mib,                               \
		     .lo = 1,                                                  \
		     .hi = 256,                                                \
		     .arg = "MIB",                                             \
		     .help = "largest scene as sent, {range} (default\n"       \
		             "64, about 1.7 million spheres; over 64\n"        \
		             "only clients of scenes in parts get it)"},       \
		    {.name = "render-idle",                                    \
		     .kind = BC_OPT_U32,                                       \
		     .dst = &(c)->render_idle_s,                               \
		     .lo = 1,                                                  \
		     .hi = 86400,                                              \
		     .arg = "S",                                               \
		     .help = "seconds a session's render state (about\n"       \
		             "250 bytes a primitive) stays once nobody\n"      \
		             "views it, and its scene encoded for\n"           \
		             "joiners (about 50) once nobody joins,\n"         \
		             "{range} (default 300); the next picture\n"       \
		             "or join makes them again"},                      \
		    {.name = "scene-memory",                                   \
		     .kind = BC_OPT_U32,                                       \
		     .dst = &(c)->scene_memory_mib,                            \
		     .lo = 1,                                                  \
		     .hi = 16777216,                                           \
		     .arg = "MIB",                                             \
		     .help = "memory for the scenes of all loaded\n"           \
		             "sessions together, {range} (default:\n"          \
		             "half the memory of the machine or of\n"          \
		             "the daemon's cgroup), at 700 bytes a\n"          \
		             "node; past it sessions without members\n"        \
		             "are unloaded, then loads and edits that\n"       \
		             "add nodes are refused (ELIMIT)"},                \
		    {.name = "client-queue",                                   \
		     .kind = BC_OPT_U32,                                       \
		     .dst = &(c)->client_queue_mib,                            \
		     .lo = 1,                                                  \
		     .hi = 1024,                                               \
		     .arg = "MIB",                                             \
		     .help = "output held for a client that has not\n"         \
		             "read it, {range} (default 32); past it\n"        \
		             "the client is dropped (a larger frame\n"         \
		             "or scene still goes, one at a time)"},           \
		    {.name = "config",                                         \
		     .kind = BC_OPT_STRING,                                    \
		     .dst = &(c)->config,                                      \
		     .arg = "FILE",                                            \
		     .help = "JSON configuration (docs/operations.md):\n"      \
		             "tokens, timeouts, and every option here\n"       \
		             "but --config, --check and --repair as a\n"       \
		             "key with '_' for '-' (\"render_idle\": 600);\n"  \
		             "options given here override it"},                \
		    {.name = "server-id",                                      \
		     .kind = BC_OPT_STRING,                                    \
		     .dst = &(c)->server_id,                                   \
		     .arg = "NAME",                                            \
		     .help = "name sent to clients (default blobcastd)"},      \
		    {.name = "check",                                          \
		     .kind = BC_OPT_STRING,                                    \
		     .dst = &(c)->check,                                       \
		     .arg = "DIR",                                             \
		     .help = "read every session of data directory\n"          \
		             "DIR as a start would, print whether\n"           \
		             "each is whole, and exit (0: all are)"},          \
		    {.name = "repair",                                         \
		     .kind = BC_OPT_FLAG,                                      \
		     .dst = &(c)->repair,                                      \
		     .help = "with --check: a session that is not\n"           \
		             "whole is set aside (files kept) and\n"           \
		             "goes on from the best state they give"},         \
		    {.name = "log",                                            \
		     .kind = BC_OPT_ENUM,                                      \
		     .dst = &(c)->log,                                         \
		     .arg = "LEVEL",                                           \
		     .help = "{choices} (default {default})",                  \
		     .names = log_names},                                      \
		    {.kind = BC_OPT_INVALID},                                  \
	}

static struct bc_args daemon_args(const struct bc_opt *opts)
{
	return (struct bc_args){
	    .prog = "blobcastd",
	    .usage = "blobcastd [options]",
	    .about = "Serves blobtree review sessions over the blobcast "
	             "protocol.\nWith no options: session \"default\" with "
	             "the embedded scene,\non 127.0.0.1:7878, data in "
	             "./blobcast-data.",
	    .footer = "Without tokens in the configuration only loopback "
	              "and Unix\nsocket clients are accepted. SIGTERM saves "
	              "and stops;\nSIGHUP reloads the tokens of the --config "
	              "file and the TLS\ncertificate and key. Unix sockets "
	              "never use TLS.",
	    .opts = opts};
}

/* A backend's name as the configuration file and --backend take it, or
 * BC_BACKEND_INVALID. */
static enum bc_backend parse_backend(const char *name)
{
	for (const struct bc_opt_name *n = backend_names; n->name; n++) {
		if (strcmp(n->name, name) == 0) {
			return (enum bc_backend)n->value;
		}
	}
	return BC_BACKEND_INVALID;
}

static int set_str(char **dst, const char *v)
{
	char *copy = bc_strdup(v);
	if (!copy) {
		return BC_ENOMEM;
	}
	bc_free(*dst);
	*dst = copy;
	return 0;
}

/* The configuration's "tokens": [{"token": ..., "role": ...}, ...]. */
static int config_tokens(struct bc_srv_config *cfg, const char *path,
                         json_t *val, struct bc_errinfo *ei)
{
	size_t i;
	json_t *tok;
	if (!json_is_array(val) || json_array_size(val) > 1024) {
		return bc_errinfo_set(ei, BC_EPARSE,
		                      "%s: tokens: expected an array of at "
		                      "most 1024",
		                      path);
	}
	cfg->tokens = bc_calloc(json_array_size(val) + 1, sizeof(*cfg->tokens));
	if (!cfg->tokens) {
		return BC_ENOMEM;
	}
	json_array_foreach(val, i, tok)
	{
		const char *t =
		    json_string_value(json_object_get(tok, "token"));
		const char *r = json_string_value(json_object_get(tok, "role"));
		if (!t || !*t || strlen(t) > BC_PROTO_MAX_TOKEN || !r ||
		    (strcmp(r, "editor") && strcmp(r, "viewer"))) {
			return bc_errinfo_set(
			    ei, BC_EPARSE,
			    "%s: tokens[%zu]: needs \"token\" "
			    "(1..%u bytes) and \"role\" "
			    "(editor|viewer)",
			    path, i, BC_PROTO_MAX_TOKEN);
		}
		if (!(cfg->tokens[i].token = bc_strdup(t))) {
			return BC_ENOMEM;
		}
		cfg->tokens[i].role = strcmp(r, "editor") == 0
		                          ? BC_PROTO_ROLE_EDITOR
		                          : BC_PROTO_ROLE_VIEWER;
		cfg->ntokens++;
	}
	return 0;
}

/* A configuration file's key for a command-line option of kind number,
 * flag or choice (its name with '_' for '-', "render_idle" for
 * --render-idle) is read into the option's own destination under the
 * option's own rules: opts is the daemon's table over the file's struct
 * cli (the command line's, merged later, wins: take_file_options).
 * backend and gl_platform, strings here since the first configuration
 * files, and the options that are no setting (--config, --check,
 * --repair) are not read here. Returns 1 when key names none of these
 * options, else 0 (*seen marks it) or BC_EPARSE with ei set. */
static int config_option(const struct bc_opt *opts, const char *path,
                         const char *key, json_t *val, uint64_t *seen,
                         struct bc_errinfo *ei)
{
	char name[32];
	int i = 0;
	size_t n = strlen(key);
	if (n >= sizeof(name) || strchr(key, '-')) {
		return 1;
	}
	for (size_t k = 0; k <= n; k++) {
		name[k] = key[k] == '_' ? '-' : key[k];
	}
	while (opts[i].kind != BC_OPT_INVALID && strcmp(opts[i].name, name)) {
		i++;
	}
	if (opts[i].kind == BC_OPT_INVALID || !strcmp(name, "backend") ||
	    !strcmp(name, "gl-platform") || !strcmp(name, "repair") ||
	    (opts[i].kind != BC_OPT_U32 && opts[i].kind != BC_OPT_FLAG &&
	     opts[i].kind != BC_OPT_ENUM)) {
		return 1;
	}
	if (opts[i].kind == BC_OPT_FLAG) {
		if (!json_is_boolean(val)) {
			return bc_errinfo_set(ei, BC_EPARSE,
			                      "%s: %s: expected true or false",
			                      path, key);
		}
		*(bool *)opts[i].dst = json_is_true(val);
	} else if (opts[i].kind == BC_OPT_U32) {
		/* The number as text, under the option's own bounds: a
		 * value that is no whole number is refused as one out of
		 * range would be. */
		char num[32] = "-";
		char range[96];
		if (json_is_integer(val)) {
			snprintf(num, sizeof(num), "%" JSON_INTEGER_FORMAT,
			         json_integer_value(val));
		}
		if (bc_opt_set(&opts[i], num)) {
			bc_opt_range_text(&opts[i], range, sizeof(range));
			return bc_errinfo_set(ei, BC_EPARSE,
			                      "%s: %s: expected a whole number "
			                      "in %s (as --%s)",
			                      path, key, range, name);
		}
	} else if (!json_is_string(val) ||
	           bc_opt_set(&opts[i], json_string_value(val))) {
		char list[256];
		bc_opt_choices_text(&opts[i], ", ", list, sizeof(list));
		return bc_errinfo_set(ei, BC_EPARSE,
		                      "%s: %s: expected one of %s", path, key,
		                      list);
	}
	*seen |= 1ull << i;
	return 0;
}

/* The configuration file's string keys, into cfg (the command line's
 * strings point into argv, the file's are copies). Returns 0 or an error
 * in ei: an unknown key (or an option's name with '-', which keys write
 * as '_'), a value that is no string, an unknown backend. */
static int config_string(struct bc_srv_config *cfg, const char *path,
                         const char *key, json_t *val, struct bc_errinfo *ei)
{
	static const char *const keys[] = {"listen",      "unix",     "data",
	                                   "server_id",   "tls_cert", "tls_key",
	                                   "gl_platform", "backend"};
	char **dst[] = {&cfg->listen,     &cfg->unix_path, &cfg->data_dir,
	                &cfg->server_id,  &cfg->tls_cert,  &cfg->tls_key,
	                &cfg->gl_platform};
	size_t i = 0;
	while (i < sizeof(keys) / sizeof(keys[0]) && strcmp(keys[i], key)) {
		i++;
	}
	if (i == sizeof(keys) / sizeof(keys[0])) {
		return bc_errinfo_set(
		    ei, BC_EPARSE, "%s: unknown key %s%s", path, key,
		    strchr(key, '-') ? " (keys write an option's '-' as '_')"
		                     : "");
	}
	if (!json_is_string(val)) {
		return bc_errinfo_set(ei, BC_EPARSE,
		                      "%s: %s: expected a string", path, key);
	}
	if (i < sizeof(dst) / sizeof(dst[0])) {
		return set_str(dst[i], json_string_value(val));
	}
	cfg->backend = parse_backend(json_string_value(val));
	if (cfg->backend == BC_BACKEND_INVALID) {
		return bc_errinfo_set(ei, BC_EPARSE, "%s: unknown backend %s",
		                      path, json_string_value(val));
	}
	return 0;
}

/* Reads the configuration file at path into cfg, and the keys of
 * command-line options (config_option) into the destinations of opts. */
static int load_config(struct bc_srv_config *cfg, const char *path,
                       const struct bc_opt *opts, uint64_t *seen,
                       struct bc_errinfo *ei)
{
	json_error_t jerr;
	json_t *root = json_load_file(path, JSON_REJECT_DUPLICATES, &jerr);
	const char *key;
	json_t *val;
	int rc = 0;
	if (!root) {
		return bc_errinfo_set(ei, BC_EPARSE, "%s:%d: %s", path,
		                      jerr.line, jerr.text);
	}
	if (!json_is_object(root)) {
		rc = bc_errinfo_set(ei, BC_EPARSE, "%s: expected an object",
		                    path);
		goto out;
	}
	json_object_foreach(root, key, val)
	{
		if (strcmp(key, "tokens") == 0) {
			if ((rc = config_tokens(cfg, path, val, ei))) {
				goto out;
			}
			continue;
		}
		if (strcmp(key, "message_timeout_ms") == 0 ||
		    strcmp(key, "idle_timeout_ms") == 0) {
			json_int_t ms =
			    json_is_integer(val) ? json_integer_value(val) : -1;
			if (ms < 0 || ms > 86400000) {
				rc =
				    bc_errinfo_set(ei, BC_EPARSE,
				                   "%s: %s: expected "
				                   "milliseconds (0..86400000)",
				                   path, key);
				goto out;
			}
			if (key[0] == 'm') {
				cfg->message_timeout_ms = (uint32_t)ms;
			} else {
				cfg->idle_timeout_ms = (uint32_t)ms;
			}
			continue;
		}
		if (strcmp(key, "allow_plaintext") == 0 ||
		    strcmp(key, "tls_allow_expired") == 0) {
			if (!json_is_boolean(val)) {
				rc = bc_errinfo_set(ei, BC_EPARSE,
				                    "%s: %s: expected true or "
				                    "false",
				                    path, key);
				goto out;
			}
			*(key[0] == 'a' ? &cfg->allow_plaintext
			                : &cfg->tls_allow_expired) =
			    json_is_true(val);
			continue;
		}
		if ((rc = config_option(opts, path, key, val, seen, ei)) <= 0) {
			if (rc) {
				goto out;
			}
			continue;
		}
		if ((rc = config_string(cfg, path, key, val, ei))) {
			goto out;
		}
	}
out:
	json_decref(root);
	return rc;
}

static void config_free(struct bc_srv_config *cfg)
{
	for (uint32_t i = 0; i < cfg->ntokens; i++) {
		bc_free(cfg->tokens[i].token);
	}
	bc_free(cfg->tokens);
	bc_free(cfg->listen);
	bc_free(cfg->unix_path);
	bc_free(cfg->data_dir);
	bc_free(cfg->gl_platform);
	bc_free(cfg->server_id);
	bc_free(cfg->tls_cert);
	bc_free(cfg->tls_key);
	memset(cfg, 0, sizeof(*cfg));
}

/* The daemon: its layers, its signals, and the file SIGHUP re-reads
 * (NULL: no --config). */
struct daemon {
	uv_loop_t *loop;
	struct bc_srv_config cfg;
	const char *config_path;
	struct bc_store *store;
	struct bc_work *work;
	struct bc_net *net;
	struct bc_sessions *ss;
	struct bc_dispatch *d;
	uv_signal_t sigterm, sigint, sighup;
	uv_timer_t deadline;
	bool stopping;
};

/* systemd's readiness protocol (sd_notify(3), Type=notify): one datagram
 * to the socket $NOTIFY_SOCKET names (a path, or @ for the abstract
 * namespace). Without that variable, nothing. Failures are logged and
 * otherwise ignored: the service manager then sees a timeout. */
static void notify_systemd(const char *state)
{
	const char *path = getenv("NOTIFY_SOCKET");
	struct sockaddr_un sa = {.sun_family = AF_UNIX};
	size_t n;
	socklen_t len;
	int fd;
	if (!path || !*path) {
		return;
	}
	n = strlen(path);
	if ((path[0] != '/' && path[0] != '@') || n >= sizeof(sa.sun_path)) {
		bc_log(BC_LOG_WARN, "NOTIFY_SOCKET %s: not a socket path",
		       path);
		return;
	}
	memcpy(sa.sun_path, path, n);
	if (path[0] == '@') {
		sa.sun_path[0] = '\0';
	}
	len = (socklen_t)(offsetof(struct sockaddr_un, sun_path) + n +
	                  (path[0] == '/'));
	fd = socket(AF_UNIX, SOCK_DGRAM | SOCK_CLOEXEC, 0);
	if (fd < 0 || sendto(fd, state, strlen(state), MSG_NOSIGNAL,
	                     (const struct sockaddr *)&sa, len) < 0) {
		bc_log(BC_LOG_WARN, "NOTIFY_SOCKET %s: cannot notify", path);
	}
	if (fd >= 0) {
		close(fd);
	}
}

/* SIGHUP also re-reads the certificate and key (a renewed certificate
 * takes effect without a restart): new connections get the new ones,
 * established ones keep theirs. A pair that does not load leaves the
 * one in use. */
static void reload_tls(struct daemon *dm)
{
	struct bc_errinfo ei = {0};
	if (!dm->cfg.tls_cert) {
		return;
	}
	if (bc_net_reload_tls(dm->net, &ei)) {
		bc_log(BC_LOG_ERROR,
		       "SIGHUP: %s; keeping the certificate in use", ei.msg);
		return;
	}
	bc_log(BC_LOG_INFO, "SIGHUP: reloaded the TLS certificate %s",
	       dm->cfg.tls_cert);
}

/* Re-reads the configuration file and replaces the access tokens, and only
 * them: the listeners, data directory and renderer are set up once. This
 * runs on the loop thread, the only one that reads the tokens (dispatch,
 * when a HELLO arrives), so the swap needs no lock. Connections that
 * already said HELLO keep the role they were given. On any error the
 * tokens in use stay. */
static void on_sighup(uv_signal_t *sig, int signum)
{
	struct daemon *dm = sig->data;
	struct bc_srv_config fresh = {0};
	struct bc_errinfo ei = {0};
	struct bc_token *old_tokens;
	uint32_t old_ntokens;
	/* The file's other settings are checked, not applied. */
	struct cli unused = {0};
	const struct bc_opt opts[] = DAEMON_OPTS(&unused);
	uint64_t seen = 0;
	(void)signum;
	if (dm->stopping) {
		return;
	}
	if (!dm->config_path) {
		bc_log(BC_LOG_INFO,
		       "SIGHUP: no --config file, nothing to reload%s",
		       dm->cfg.tls_cert ? " but the TLS certificate" : "");
		reload_tls(dm);
		return;
	}
	if (load_config(&fresh, dm->config_path, opts, &seen, &ei)) {
		bc_log(BC_LOG_ERROR, "SIGHUP: %s; keeping the %u tokens in use",
		       ei.msg[0] ? ei.msg : bc_strerror(ei.code),
		       dm->cfg.ntokens);
		config_free(&fresh);
		return;
	}
	old_tokens = dm->cfg.tokens;
	old_ntokens = dm->cfg.ntokens;
	dm->cfg.tokens = fresh.tokens;
	dm->cfg.ntokens = fresh.ntokens;
	if (bc_net_tokens_in_clear(dm->net) && !dm->cfg.allow_plaintext) {
		/* The same rule as at start: no tokens in clear. */
		dm->cfg.tokens = old_tokens;
		dm->cfg.ntokens = old_ntokens;
		bc_log(BC_LOG_ERROR,
		       "SIGHUP: %s has tokens but %s is plain TCP reachable "
		       "from other hosts (no TLS, no --allow-plaintext); "
		       "keeping the %u tokens in use",
		       dm->config_path, dm->cfg.listen, old_ntokens);
		config_free(&fresh);
		return;
	}
	fresh.tokens = old_tokens;
	fresh.ntokens = old_ntokens;
	config_free(&fresh);
	reload_tls(dm);
	bc_log(BC_LOG_INFO,
	       "SIGHUP: reloaded %u tokens from %s (only tokens are reloaded: "
	       "other settings take effect on restart)",
	       dm->cfg.ntokens, dm->config_path);
	bc_net_warn_exposed(dm->net);
}

/* The stop's deadline: what did not finish by then is left (every
 * acknowledged edit is in a journal already). */
static void deadline_passed(uv_timer_t *t)
{
	(void)t;
	bc_log(BC_LOG_WARN,
	       "stopping: %u ms passed; exiting without waiting "
	       "for the work still running",
	       BC_SRV_STOP_MS);
	_exit(0);
}

/* Closes the daemon's own handles. */
static void close_handles(struct daemon *dm)
{
	uv_close((uv_handle_t *)&dm->sigterm, NULL);
	uv_close((uv_handle_t *)&dm->sigint, NULL);
	uv_close((uv_handle_t *)&dm->sighup, NULL);
	/* Closing the handle restored SIGHUP's default action, which would
	 * kill the daemon before the loop has finished closing. */
	signal(SIGHUP, SIG_IGN);
}

static void on_signal(uv_signal_t *sig, int signum)
{
	struct daemon *dm = sig->data;
	if (dm->stopping) {
		return;
	}
	bc_log(BC_LOG_INFO, "signal %d: saving sessions and stopping", signum);
	notify_systemd("STOPPING=1");
	dm->stopping = true;
	uv_timer_init(dm->loop, &dm->deadline);
	uv_timer_start(&dm->deadline, deadline_passed, BC_SRV_STOP_MS, 0);
	uv_unref((uv_handle_t *)&dm->deadline);
	bc_sessions_save_all(dm->ss, BC_SRV_STOP_SAVE_MS);
	bc_net_close_all(dm->net);
	bc_dispatch_free(dm->d);
	dm->d = NULL;
	bc_sessions_free(dm->ss);
	dm->ss = NULL;
	if (!bc_work_stop(dm->work, BC_SRV_STOP_WORKERS_MS)) {
		/* A renderer call is still running on what the work layer
		 * holds: nothing of it can be freed. */
		_exit(0);
	}
	dm->work = NULL;
	close_handles(dm);
}

/* The work layer's results go to the sessions layer. */
static void job_done(void *ud, const struct bc_work_done *d)
{
	struct daemon *dm = ud;
	if (dm->ss) {
		bc_sessions_job_done(dm->ss, d);
	}
}

/* The options the configuration file gave (fseen, in fopts' destinations)
 * that the command line did not (cseen) become the command line's (in
 * opts'), the log level taken at once. */
static void take_file_options(const struct bc_opt *opts,
                              const struct bc_opt *fopts, uint64_t fseen,
                              uint64_t cseen)
{
	for (int i = 0; opts[i].kind != BC_OPT_INVALID; i++) {
		if (!(fseen >> i & 1u) || (cseen >> i & 1u)) {
			continue;
		}
		if (opts[i].kind == BC_OPT_FLAG) {
			*(bool *)opts[i].dst = *(const bool *)fopts[i].dst;
		} else if (opts[i].kind == BC_OPT_U32) {
			*(uint32_t *)opts[i].dst =
			    *(const uint32_t *)fopts[i].dst;
		} else if (opts[i].kind == BC_OPT_ENUM) {
			*(int *)opts[i].dst = *(const int *)fopts[i].dst;
			if (!strcmp(opts[i].name, "log")) {
				bc_log_init((enum bc_log_level) *
				            (const int *)opts[i].dst);
			}
		}
	}
}

/* Command-line options over the file's (c: what the command line gave). */
static void apply_cli(struct bc_srv_config *cfg, const struct cli *c,
                      const struct bc_args *args)
{
	if (c->listen) {
		set_str(&cfg->listen, c->listen);
	}
	if (c->unix_path) {
		set_str(&cfg->unix_path, c->unix_path);
	}
	if (c->data_dir) {
		set_str(&cfg->data_dir, c->data_dir);
	}
	if (bc_args_given(args, "gl-platform")) {
		set_str(&cfg->gl_platform, platform_names[c->gl_platform].name);
	}
	if (c->server_id) {
		set_str(&cfg->server_id, c->server_id);
	}
	if (c->backend) {
		cfg->backend = (enum bc_backend)c->backend;
	}
	if (c->tls_cert) {
		set_str(&cfg->tls_cert, c->tls_cert);
	}
	if (c->tls_key) {
		set_str(&cfg->tls_key, c->tls_key);
	}
	cfg->allow_plaintext = cfg->allow_plaintext || c->allow_plaintext;
	cfg->tls_allow_expired = cfg->tls_allow_expired || c->tls_allow_expired;
	cfg->simd = (enum bc_simd)c->simd;
	cfg->video_encoder = (enum bc_video_backend)c->video_encoder;
	cfg->x264_preset = NULL;
	for (size_t i = 0; c->x264_preset && preset_names[i].name; i++) {
		if (preset_names[i].value == c->x264_preset) {
			cfg->x264_preset = preset_names[i].name;
		}
	}
	cfg->no_damage = c->no_damage;
	cfg->no_pace = c->no_pace;
	cfg->frame_budget_ms = c->frame_budget_ms;
	cfg->render_threads = c->render_threads;
	cfg->view_cache_mib = c->view_cache_mib;
	cfg->max_scene_mib = c->max_scene_mib;
	cfg->client_queue_mib = c->client_queue_mib;
	cfg->render_idle_s = c->render_idle_s;
	cfg->scene_memory_mib = c->scene_memory_mib;
}

/* Defaults for what neither gave, and the checks between options. Returns
 * 0, or 1 after saying what is wrong. */
static int settle_config(struct bc_srv_config *cfg)
{
	if (!cfg->listen) {
		set_str(&cfg->listen, "127.0.0.1:7878");
	}
	if (strcmp(cfg->listen, "none") == 0) {
		bc_free(cfg->listen);
		cfg->listen = NULL;
	}
	if (!cfg->data_dir) {
		set_str(&cfg->data_dir, "blobcast-data");
	}
	if (!cfg->server_id) {
		set_str(&cfg->server_id, "blobcastd");
	}
	if (!cfg->backend) {
		cfg->backend = BC_BACKEND_TILED;
	}
	if (cfg->tls_key && !cfg->tls_cert) {
		fprintf(stderr, "blobcastd: --tls-key needs --tls-cert\n");
		return 1;
	}
	if (cfg->tls_cert && !cfg->listen) {
		fprintf(stderr, "blobcastd: --tls-cert needs a TCP listener "
		                "(--listen); Unix sockets never use TLS\n");
		return 1;
	}
	if (strlen(cfg->server_id) > BC_PROTO_MAX_NAME) {
		fprintf(stderr, "blobcastd: --server-id longer than %u bytes\n",
		        BC_PROTO_MAX_NAME);
		return 1;
	}
	return 0;
}

/* The smallest limit in file of cgroup dir (under root) and the cgroups
 * above it, if below lim. dir is changed. */
static uint64_t cgroup_limit(const char *root, char *dir, const char *file,
                             uint64_t lim)
{
	char path[700];
	while (dir) {
		size_t n = strlen(dir);
		unsigned long long v;
		FILE *m;
		snprintf(path, sizeof(path), "%s%s/%s", root, dir, file);
		if ((m = fopen(path, "r"))) {
			if (fscanf(m, "%llu", &v) == 1 && v < lim) {
				lim = v; /* "max" reads as no number */
			}
			fclose(m);
		}
		while (n > 0 && dir[n - 1] != '/') {
			n--;
		}
		dir = n > 1 ? (dir[n - 1] = '\0', dir) : NULL;
	}
	return lim;
}

/* The memory this process may use: the machine's, or less where its
 * cgroup or one above it has a limit (cgroup v2 memory.max: systemd's
 * MemoryMax, a container's; v1 memory.limit_in_bytes). */
static uint64_t memory_limit(void)
{
	uint64_t lim =
	    (uint64_t)sysconf(_SC_PHYS_PAGES) * (uint64_t)sysconf(_SC_PAGESIZE);
	char line[512];
	FILE *f = fopen("/proc/self/cgroup", "r");
	while (f && fgets(line, sizeof(line), f)) {
		char *dir = strstr(line, ":/");
		line[strcspn(line, "\n")] = '\0';
		if (strncmp(line, "0::/", 4) == 0) {
			lim = cgroup_limit("/sys/fs/cgroup", line + 3,
			                   "memory.max", lim);
		} else if (dir && strstr(line, ":memory:")) {
			lim = cgroup_limit("/sys/fs/cgroup/memory", dir + 1,
			                   "memory.limit_in_bytes", lim);
		}
	}
	if (f) {
		fclose(f);
	}
	return lim;
}

/* --scene-memory (MiB; 0: half of memory_limit()) as scene nodes. */
static uint64_t scene_nodes(uint32_t mib)
{
	uint64_t bytes = mib ? (uint64_t)mib << 20 : memory_limit() / 2u;
	uint64_t nodes = bytes / BC_SRV_NODE_COST;
	bc_log(BC_LOG_INFO,
	       "scenes: at most %llu nodes in all loaded sessions "
	       "(--scene-memory %llu MiB, %u bytes a node)",
	       (unsigned long long)nodes, (unsigned long long)(bytes >> 20),
	       BC_SRV_NODE_COST);
	return nodes ? nodes : 1u;
}

/* Makes the layers bottom up and wires them. Returns 0 or an error. */
static int start(struct daemon *dm, struct bc_errinfo *ei)
{
	int rc;
	if ((rc = bc_store_open(&dm->store, dm->cfg.data_dir, ei))) {
		return rc;
	}
	if ((rc = bc_work_start(
	         &dm->work,
	         &(struct bc_work_opts){
	             .loop = dm->loop,
	             .backend = dm->cfg.backend,
	             .gl_platform = dm->cfg.gl_platform,
	             .simd = dm->cfg.simd,
	             .workers = dm->cfg.render_threads,
	             .budget_ms = dm->cfg.frame_budget_ms,
	             .no_damage = dm->cfg.no_damage,
	             .view_cap = (size_t)dm->cfg.view_cache_mib << 20,
	             .done = job_done,
	             .ud = dm,
	         },
	         ei))) {
		return rc;
	}
	if (bc_net_new(&dm->net, dm->loop, &dm->cfg)) {
		return bc_errinfo_set(ei, BC_ENOMEM, "out of memory");
	}
	if ((rc = bc_sessions_new(
	         &dm->ss,
	         &(struct bc_sessions_opts){
	             .loop = dm->loop,
	             .link = bc_net_link(dm->net),
	             .work = dm->work,
	             .store = dm->store,
	             .no_damage = dm->cfg.no_damage,
	             .max_scene_bytes = (size_t)dm->cfg.max_scene_mib << 20,
	             .render_idle_ms = dm->cfg.render_idle_s * 1000u,
	             .scene_nodes = scene_nodes(dm->cfg.scene_memory_mib),
	             .video =
	                 {
	                     .backend = dm->cfg.video_encoder,
	                     .x264_preset = dm->cfg.x264_preset,
	                 },
	         },
	         ei))) {
		return rc;
	}
	if ((rc = bc_dispatch_new(&dm->d,
	                          &(struct bc_dispatch_opts){
	                              .loop = dm->loop,
	                              .link = bc_net_link(dm->net),
	                              .sessions = dm->ss,
	                              .work = dm->work,
	                              .cfg = &dm->cfg,
	                          },
	                          ei))) {
		return rc;
	}
	bc_net_set_dispatch(dm->net, dm->d);
	return bc_net_listen(dm->net, ei);
}

/* Undoes a start that failed part way, running the loop until its handles
 * are closed. */
static void abandon(struct daemon *dm)
{
	if (dm->net) {
		bc_net_close_all(dm->net);
	}
	bc_dispatch_free(dm->d);
	bc_sessions_free(dm->ss);
	if (!bc_work_stop(dm->work, BC_SRV_STOP_WORKERS_MS)) {
		_exit(1);
	}
	uv_run(dm->loop, UV_RUN_DEFAULT);
}

static void watch_signals(struct daemon *dm)
{
	uv_signal_init(dm->loop, &dm->sigterm);
	uv_signal_init(dm->loop, &dm->sigint);
	uv_signal_init(dm->loop, &dm->sighup);
	dm->sigterm.data = dm->sigint.data = dm->sighup.data = dm;
	uv_signal_start(&dm->sigterm, on_signal, SIGTERM);
	uv_signal_start(&dm->sigint, on_signal, SIGINT);
	uv_signal_start(&dm->sighup, on_sighup, SIGHUP);
}

int main(int argc, char **argv)
{
	static struct daemon dm;
	struct bc_errinfo ei = {0};
	struct cli cli = {.log = BC_LOG_INFO}, fcli = {0};
	const struct bc_opt opts[] = DAEMON_OPTS(&cli);
	const struct bc_opt fopts[] = DAEMON_OPTS(&fcli);
	struct bc_args args = daemon_args(opts);
	uint64_t fseen = 0;
	int rc = 1;
	bc_heap_policy();
	if (bc_args_parse(&args, argc, argv)) {
		return args.status;
	}
	if (args.npos) {
		return bc_args_error(&args, "unexpected argument '%s'",
		                     args.pos[0]);
	}
	bc_log_init((enum bc_log_level)cli.log);
	if (cli.check) {
		return bc_sessions_check(cli.check, cli.repair, stdout);
	}
	if (cli.repair) {
		return bc_args_error(&args, "--repair goes with --check DIR");
	}
	dm.config_path = cli.config;
	if (cli.config &&
	    load_config(&dm.cfg, cli.config, fopts, &fseen, &ei)) {
		fprintf(stderr, "blobcastd: %s\n", ei.msg);
		goto out;
	}
	take_file_options(opts, fopts, fseen, args.seen);
	apply_cli(&dm.cfg, &cli, &args);
	if (settle_config(&dm.cfg)) {
		goto out;
	}
	/* A write to a closed connection returns EPIPE instead of killing
	 * the daemon. A SIGHUP during start-up is ignored rather than fatal;
	 * its handler is installed once the listeners are up. */
	signal(SIGPIPE, SIG_IGN);
	signal(SIGHUP, SIG_IGN);
	dm.loop = uv_default_loop();
	/* dispatch reports the loop's busy turns from its idle time. */
	uv_loop_configure(dm.loop, UV_METRICS_IDLE_TIME);
	/* The H.264 encoder's module: looked for now, so that the log says
	 * at once when encoding 4 will be refused; opened when a client
	 * first asks for it (frames.c). */
	{
		struct bc_errinfo vei = {0};
		if (bc_vstream_find(&vei)) {
			bc_log(BC_LOG_WARN,
			       "%s; views of encoding 4 are refused", vei.msg);
		}
	}
	if (start(&dm, &ei)) {
		fprintf(stderr, "blobcastd: %s\n", ei.msg);
		abandon(&dm);
		goto out;
	}
	watch_signals(&dm);
	bc_net_announce(dm.net);
	fprintf(stderr, "blobcastd: backend %s, data in %s\n",
	        bc_backend_name(dm.cfg.backend), dm.cfg.data_dir);
	/* Sessions restored and listeners up: clients may come. */
	notify_systemd("READY=1");
	uv_run(dm.loop, UV_RUN_DEFAULT);
	rc = 0;
out:
	if (dm.loop) {
		uv_loop_close(dm.loop);
	}
	bc_net_free(dm.net);
	bc_store_close(dm.store);
	config_free(&dm.cfg);
	bc_vstream_settle();
	return rc;
}
