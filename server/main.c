/*
 * blobcastd: options, configuration file, start-up and shutdown.
 *
 * With no arguments it serves the embedded default scene in session
 * "default" on 127.0.0.1:7878 with ./blobcast-data as its data directory.
 * SIGTERM or SIGINT saves every session and stops; SIGHUP re-reads the
 * access tokens of the --config file.
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
#include "addr.h"
#include "net_impl.h"
#include "server.h"
#include "tls.h"

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
static const struct bc_opt_name log_names[] = {
    {"silent", BC_LOG_SILENT}, {"error", BC_LOG_ERROR}, {"warn", BC_LOG_WARN},
    {"info", BC_LOG_INFO},     {"debug", BC_LOG_DEBUG}, {NULL, 0}};

/* The command line, before it is merged over the configuration file.
 * Strings point into argv; 0 and NULL mean "not given". */
struct cli {
	const char *listen, *unix_path, *data_dir, *config;
	const char *tls_cert, *tls_key, *server_id;
	int backend, gl_platform, simd, log;
	bool allow_plaintext, no_damage;
	uint32_t frame_budget_ms;
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
		    {.name = "no-damage",                                      \
		     .kind = BC_OPT_FLAG,                                      \
		     .dst = &(c)->no_damage,                                   \
		     .help = "edits re-render whole views instead of\n"        \
		             "the tiles they change (to compare)"},            \
		    {.name = "frame-budget",                                   \
		     .kind = BC_OPT_U32,                                       \
		     .dst = &(c)->frame_budget_ms,                             \
		     .lo = 1,                                                  \
		     .hi = 600000,                                             \
		     .arg = "MS",                                              \
		     .help = "time one refinement step may take,\n"            \
		             "{range} (default 2000); past it the\n"           \
		             "picture stays at its coarser level"},            \
		    {.name = "config",                                         \
		     .kind = BC_OPT_STRING,                                    \
		     .dst = &(c)->config,                                      \
		     .arg = "FILE",                                            \
		     .help = "JSON configuration (docs/operations.md);\n"      \
		             "options given here override it"},                \
		    {.name = "server-id",                                      \
		     .kind = BC_OPT_STRING,                                    \
		     .dst = &(c)->server_id,                                   \
		     .arg = "NAME",                                            \
		     .help = "name sent to clients (default blobcastd)"},      \
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

static int load_config(struct bc_srv_config *cfg, const char *path,
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
			size_t i;
			json_t *tok;
			if (!json_is_array(val) ||
			    json_array_size(val) > 1024) {
				rc = bc_errinfo_set(ei, BC_EPARSE,
				                    "%s: tokens: expected an "
				                    "array of at most 1024",
				                    path);
				goto out;
			}
			cfg->tokens = bc_calloc(json_array_size(val) + 1,
			                        sizeof(*cfg->tokens));
			if (!cfg->tokens) {
				rc = BC_ENOMEM;
				goto out;
			}
			json_array_foreach(val, i, tok)
			{
				const char *t = json_string_value(
				    json_object_get(tok, "token"));
				const char *r = json_string_value(
				    json_object_get(tok, "role"));
				if (!t || !*t ||
				    strlen(t) > BC_PROTO_MAX_TOKEN || !r ||
				    (strcmp(r, "editor") &&
				     strcmp(r, "viewer"))) {
					rc = bc_errinfo_set(
					    ei, BC_EPARSE,
					    "%s: tokens[%zu]: needs "
					    "\"token\" (1..%u bytes) and "
					    "\"role\" (editor|viewer)",
					    path, i, BC_PROTO_MAX_TOKEN);
					goto out;
				}
				if (!(cfg->tokens[i].token = bc_strdup(t))) {
					rc = BC_ENOMEM;
					goto out;
				}
				cfg->tokens[i].role =
				    strcmp(r, "editor") == 0
				        ? BC_PROTO_ROLE_EDITOR
				        : BC_PROTO_ROLE_VIEWER;
				cfg->ntokens++;
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
		if (strcmp(key, "allow_plaintext") == 0) {
			if (!json_is_boolean(val)) {
				rc = bc_errinfo_set(ei, BC_EPARSE,
				                    "%s: %s: expected true or "
				                    "false",
				                    path, key);
				goto out;
			}
			cfg->allow_plaintext = json_is_true(val);
			continue;
		}
		if (!json_is_string(val)) {
			rc = bc_errinfo_set(ei, BC_EPARSE,
			                    "%s: %s: expected a string", path,
			                    key);
			goto out;
		}
		if (strcmp(key, "listen") == 0) {
			rc = set_str(&cfg->listen, json_string_value(val));
		} else if (strcmp(key, "unix") == 0) {
			rc = set_str(&cfg->unix_path, json_string_value(val));
		} else if (strcmp(key, "data") == 0) {
			rc = set_str(&cfg->data_dir, json_string_value(val));
		} else if (strcmp(key, "server_id") == 0) {
			rc = set_str(&cfg->server_id, json_string_value(val));
		} else if (strcmp(key, "tls_cert") == 0) {
			rc = set_str(&cfg->tls_cert, json_string_value(val));
		} else if (strcmp(key, "tls_key") == 0) {
			rc = set_str(&cfg->tls_key, json_string_value(val));
		} else if (strcmp(key, "gl_platform") == 0) {
			rc = set_str(&cfg->gl_platform, json_string_value(val));
		} else if (strcmp(key, "backend") == 0) {
			cfg->backend = parse_backend(json_string_value(val));
			if (cfg->backend == BC_BACKEND_INVALID) {
				rc = bc_errinfo_set(
				    ei, BC_EPARSE, "%s: unknown backend %s",
				    path, json_string_value(val));
			}
		} else {
			rc = bc_errinfo_set(ei, BC_EPARSE, "%s: unknown key %s",
			                    path, key);
		}
		if (rc) {
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

/* SIGHUP's handle and the file it re-reads (NULL: no --config). They live
 * here rather than in struct bc_srv because only this file uses them. */
static uv_signal_t sighup;
static const char *config_path;

/* Without tokens only loopback and Unix-socket clients get in: say so when
 * the TCP listener is reachable from other hosts, where an operator would
 * otherwise see connections refused with no hint at start. */
static void warn_if_exposed(struct bc_srv *srv)
{
	struct sockaddr_storage sa;
	int len = sizeof(sa);
	if (!srv->has_tcp || srv->cfg.ntokens > 0 ||
	    uv_tcp_getsockname(&srv->tcp_listener, (struct sockaddr *)&sa,
	                       &len) != 0 ||
	    bc_addr_is_loopback((const struct sockaddr *)&sa)) {
		return;
	}
	bc_log(BC_LOG_WARN,
	       "listening on %s with no tokens configured: only loopback "
	       "and Unix-socket clients will be accepted (docs/operations.md, "
	       "Access)",
	       srv->cfg.listen);
}

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
static void reload_tls(struct bc_srv *srv)
{
	struct bc_tls_ctx *fresh = NULL;
	struct bc_errinfo ei = {0};
	if (!srv->tls) {
		return;
	}
	if (bc_tls_ctx_new(
	        &fresh, srv->cfg.tls_cert,
	        srv->cfg.tls_key ? srv->cfg.tls_key : srv->cfg.tls_cert, &ei)) {
		bc_log(BC_LOG_ERROR,
		       "SIGHUP: %s; keeping the certificate in use", ei.msg);
		return;
	}
	bc_tls_ctx_free(srv->tls);
	srv->tls = fresh;
	bc_log(BC_LOG_INFO, "SIGHUP: reloaded the TLS certificate %s",
	       srv->cfg.tls_cert);
}

/* Re-reads the configuration file and replaces the access tokens, and only
 * them: the listeners, data directory and renderer are set up once. This
 * runs on the loop thread, the only one that reads the tokens (net.c, when
 * a HELLO arrives), so the swap needs no lock. Connections that already
 * said HELLO keep the role they were given. On any error the tokens in use
 * stay. */
static void on_sighup(uv_signal_t *sig, int signum)
{
	struct bc_srv *srv = sig->data;
	struct bc_srv_config fresh = {0};
	struct bc_errinfo ei = {0};
	struct bc_token *old_tokens;
	uint32_t old_ntokens;
	int rc;
	(void)signum;
	if (srv->stopping) {
		return;
	}
	if (!config_path) {
		bc_log(BC_LOG_INFO,
		       "SIGHUP: no --config file, nothing to reload%s",
		       srv->tls ? " but the TLS certificate" : "");
		reload_tls(srv);
		return;
	}
	rc = load_config(&fresh, config_path, &ei);
	if (rc) {
		bc_log(BC_LOG_ERROR, "SIGHUP: %s; keeping the %u tokens in use",
		       ei.msg[0] ? ei.msg : bc_strerror(rc), srv->cfg.ntokens);
		config_free(&fresh);
		return;
	}
	old_tokens = srv->cfg.tokens;
	old_ntokens = srv->cfg.ntokens;
	srv->cfg.tokens = fresh.tokens;
	srv->cfg.ntokens = fresh.ntokens;
	if (bc_net_tokens_in_clear(srv) && !srv->cfg.allow_plaintext) {
		/* The same rule as at start: no tokens in clear. */
		srv->cfg.tokens = old_tokens;
		srv->cfg.ntokens = old_ntokens;
		bc_log(BC_LOG_ERROR,
		       "SIGHUP: %s has tokens but %s is plain TCP reachable "
		       "from other hosts (no TLS, no --allow-plaintext); "
		       "keeping the %u tokens in use",
		       config_path, srv->cfg.listen, old_ntokens);
		config_free(&fresh);
		return;
	}
	fresh.tokens = old_tokens;
	fresh.ntokens = old_ntokens;
	config_free(&fresh);
	reload_tls(srv);
	bc_log(BC_LOG_INFO,
	       "SIGHUP: reloaded %u tokens from %s (only tokens are reloaded: "
	       "other settings take effect on restart)",
	       srv->cfg.ntokens, config_path);
	warn_if_exposed(srv);
}

static void on_signal(uv_signal_t *sig, int signum)
{
	struct bc_srv *srv = sig->data;
	if (srv->stopping) {
		return;
	}
	bc_log(BC_LOG_INFO, "signal %d: saving sessions and stopping", signum);
	notify_systemd("STOPPING=1");
	srv->stopping = true;
	bc_sessions_save_all(srv);
	bc_net_close_all(srv);
	bc_sessions_free(srv);
	bc_rthread_stop(srv);
	uv_close((uv_handle_t *)&srv->sigterm, NULL);
	uv_close((uv_handle_t *)&srv->sigint, NULL);
	uv_close((uv_handle_t *)&sighup, NULL);
	/* Closing the handle restored SIGHUP's default action, which would
	 * kill the daemon before the loop has finished closing. */
	signal(SIGHUP, SIG_IGN);
}

static void print_endpoints(struct bc_srv *srv)
{
	if (srv->has_tcp) {
		struct sockaddr_storage sa;
		int len = sizeof(sa);
		char host[64] = "?";
		int port = 0;
		uv_tcp_getsockname(&srv->tcp_listener, (struct sockaddr *)&sa,
		                   &len);
		if (sa.ss_family == AF_INET) {
			struct sockaddr_in *in = (struct sockaddr_in *)&sa;
			uv_ip4_name(in, host, sizeof(host));
			port = ntohs(in->sin_port);
		} else if (sa.ss_family == AF_INET6) {
			struct sockaddr_in6 *in6 = (struct sockaddr_in6 *)&sa;
			uv_ip6_name(in6, host, sizeof(host));
			port = ntohs(in6->sin6_port);
		}
		fprintf(stderr, "blobcastd: listening on %s:%d\n", host, port);
	}
	if (srv->has_unix) {
		fprintf(stderr, "blobcastd: listening on unix:%s\n",
		        srv->cfg.unix_path);
	}
}

int main(int argc, char **argv)
{
	struct bc_srv srv;
	struct bc_errinfo ei = {0};
	const char *config = NULL;
	struct cli cli = {.log = BC_LOG_INFO};
	const struct bc_opt opts[] = DAEMON_OPTS(&cli);
	struct bc_args args = daemon_args(opts);
	int rc = 1;

	memset(&srv, 0, sizeof(srv));
	if (bc_args_parse(&args, argc, argv)) {
		return args.status;
	}
	if (args.npos) {
		return bc_args_error(&args, "unexpected argument '%s'",
		                     args.pos[0]);
	}
	bc_log_init((enum bc_log_level)cli.log);
	config = cli.config;
	if (config && load_config(&srv.cfg, config, &ei)) {
		fprintf(stderr, "blobcastd: %s\n", ei.msg);
		goto out;
	}
	/* Command-line options override the file. */
	if (cli.listen) {
		set_str(&srv.cfg.listen, cli.listen);
	}
	if (cli.unix_path) {
		set_str(&srv.cfg.unix_path, cli.unix_path);
	}
	if (cli.data_dir) {
		set_str(&srv.cfg.data_dir, cli.data_dir);
	}
	if (bc_args_given(&args, "gl-platform")) {
		set_str(&srv.cfg.gl_platform,
		        platform_names[cli.gl_platform].name);
	}
	if (cli.server_id) {
		set_str(&srv.cfg.server_id, cli.server_id);
	}
	if (cli.backend) {
		srv.cfg.backend = (enum bc_backend)cli.backend;
	}
	if (cli.tls_cert) {
		set_str(&srv.cfg.tls_cert, cli.tls_cert);
	}
	if (cli.tls_key) {
		set_str(&srv.cfg.tls_key, cli.tls_key);
	}
	srv.cfg.allow_plaintext =
	    srv.cfg.allow_plaintext || cli.allow_plaintext;
	srv.cfg.simd = (enum bc_simd)cli.simd;
	srv.cfg.no_damage = cli.no_damage;
	srv.cfg.frame_budget_ms = cli.frame_budget_ms;
	if (!srv.cfg.listen) {
		set_str(&srv.cfg.listen, "127.0.0.1:7878");
	}
	if (strcmp(srv.cfg.listen, "none") == 0) {
		bc_free(srv.cfg.listen);
		srv.cfg.listen = NULL;
	}
	if (!srv.cfg.data_dir) {
		set_str(&srv.cfg.data_dir, "blobcast-data");
	}
	if (!srv.cfg.server_id) {
		set_str(&srv.cfg.server_id, "blobcastd");
	}
	if (!srv.cfg.backend) {
		srv.cfg.backend = BC_BACKEND_TILED;
	}
	if (srv.cfg.tls_key && !srv.cfg.tls_cert) {
		fprintf(stderr, "blobcastd: --tls-key needs --tls-cert\n");
		goto out;
	}
	if (srv.cfg.tls_cert && !srv.cfg.listen) {
		fprintf(stderr, "blobcastd: --tls-cert needs a TCP listener "
		                "(--listen); Unix sockets never use TLS\n");
		goto out;
	}
	if (strlen(srv.cfg.server_id) > BC_PROTO_MAX_NAME) {
		fprintf(stderr, "blobcastd: --server-id longer than %u bytes\n",
		        BC_PROTO_MAX_NAME);
		goto out;
	}
	/* A write to a closed connection returns EPIPE instead of killing
	 * the daemon. A SIGHUP during start-up is ignored rather than fatal;
	 * its handler is installed once the listeners are up. */
	signal(SIGPIPE, SIG_IGN);
	signal(SIGHUP, SIG_IGN);
	config_path = config;
	srv.loop = uv_default_loop();
	srv.started_ms = uv_now(srv.loop);
	if (bc_store_open(&srv.store, srv.cfg.data_dir, &ei) ||
	    bc_rthread_start(&srv, &ei) || bc_sessions_restore(&srv, &ei) ||
	    bc_net_listen(&srv, &ei)) {
		fprintf(stderr, "blobcastd: %s\n", ei.msg);
		if (srv.rt) {
			bc_sessions_free(&srv);
			bc_rthread_stop(&srv);
			bc_net_close_all(&srv);
			uv_run(srv.loop, UV_RUN_DEFAULT);
		}
		goto out;
	}
	uv_signal_init(srv.loop, &srv.sigterm);
	uv_signal_init(srv.loop, &srv.sigint);
	srv.sigterm.data = srv.sigint.data = &srv;
	uv_signal_start(&srv.sigterm, on_signal, SIGTERM);
	uv_signal_start(&srv.sigint, on_signal, SIGINT);
	uv_signal_init(srv.loop, &sighup);
	sighup.data = &srv;
	uv_signal_start(&sighup, on_sighup, SIGHUP);
	print_endpoints(&srv);
	warn_if_exposed(&srv);
	fprintf(stderr, "blobcastd: backend %s, data in %s\n",
	        bc_backend_name(srv.cfg.backend), srv.cfg.data_dir);
	/* Sessions restored and listeners up: clients may come. */
	notify_systemd("READY=1");
	uv_run(srv.loop, UV_RUN_DEFAULT);
	rc = 0;
out:
	if (srv.loop) {
		uv_loop_close(srv.loop);
	}
	bc_store_close(srv.store);
	bc_tls_ctx_free(srv.tls);
	config_free(&srv.cfg);
	return rc;
}
