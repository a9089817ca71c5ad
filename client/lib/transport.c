/*
 * The byte stream under a connection: the socket as it is, or TLS over it
 * (OpenSSL on the non-blocking socket, waits bounded by the caller's
 * deadline). A TLS connection verifies the server's certificate against
 * the system's trust store or a given CA file, and its name against the
 * host the address named, unless told to be insecure by name; the HELLO
 * (and its token) is only written once the handshake has succeeded.
 */
#include <arpa/inet.h>
#include <errno.h>
#include <poll.h>
#include <pthread.h>
#include <signal.h>
#include <stdio.h>
#include <string.h>
#include <sys/socket.h>
#include <time.h>
#include <unistd.h>

#include <openssl/err.h>
#include <openssl/ssl.h>
#include <openssl/x509v3.h>

#include "blobcast/clock.h"
#include "client_impl.h"

int bc__client_ms_left(double deadline)
{
	double left;
	if (deadline < 0.0) {
		return -1;
	}
	left = deadline - bc_clock_ms();
	if (left <= 0.0) {
		return 0;
	}
	/* Round up so that poll never wakes just before the deadline and
	 * spins on a zero timeout. */
	return left > 2e9 ? 2000000000 : (int)left + 1;
}

/* Waits until fd is readable (POLLIN) or writable (POLLOUT). Returns 1,
 * 0 at the deadline, or -1 with errno. */
static int wait_fd(int fd, short events, double deadline)
{
	struct pollfd p = {.fd = fd, .events = events};
	int k;
	do {
		k = poll(&p, 1, bc__client_ms_left(deadline));
	} while (k < 0 && errno == EINTR);
	return k;
}

/* OpenSSL writes to the socket with write(), which raises SIGPIPE when the
 * server has gone; a library must not kill its program for that. SIGPIPE
 * is blocked around OpenSSL's writes and one it raised is taken back. */
struct pipe_guard {
	sigset_t old;
	bool was_pending;
};

static void pipe_block(struct pipe_guard *g)
{
	sigset_t pipe, pending;
	sigemptyset(&pipe);
	sigaddset(&pipe, SIGPIPE);
	sigpending(&pending);
	g->was_pending = sigismember(&pending, SIGPIPE) == 1;
	pthread_sigmask(SIG_BLOCK, &pipe, &g->old);
}

static void pipe_unblock(struct pipe_guard *g)
{
	sigset_t pipe, pending;
	int saved = errno;
	sigemptyset(&pipe);
	sigaddset(&pipe, SIGPIPE);
	sigpending(&pending);
	if (!g->was_pending && sigismember(&pending, SIGPIPE) == 1) {
		struct timespec zero = {0, 0};
		(void)sigtimedwait(&pipe, NULL, &zero);
	}
	pthread_sigmask(SIG_SETMASK, &g->old, NULL);
	errno = saved;
}

/* OpenSSL's latest error as text, queue cleared. */
static void ssl_reason(char *buf, size_t len)
{
	unsigned long e = ERR_peek_last_error();
	if (e) {
		ERR_error_string_n(e, buf, len);
	} else if (errno) {
		snprintf(buf, len, "%s", strerror(errno));
	} else {
		snprintf(buf, len,
		         "the connection closed during the handshake");
	}
	ERR_clear_error();
}

int bc__client_tls_start(struct bc_client *c, const char *host,
                         const char *ca_file, bool insecure, double deadline)
{
	SSL_CTX *ctx;
	SSL *ssl;
	unsigned char ip[16];
	bool is_ip = inet_pton(AF_INET, host, ip) == 1 ||
	             inet_pton(AF_INET6, host, ip) == 1;
	char why[256];
	ERR_clear_error();
	if (!(ctx = SSL_CTX_new(TLS_client_method()))) {
		ssl_reason(why, sizeof(why));
		return bc__client_fail(c, BC_EIO, "TLS: %s", why);
	}
	c->ssl_ctx = ctx;
	SSL_CTX_set_min_proto_version(ctx, TLS1_2_VERSION);
	SSL_CTX_set_mode(ctx, SSL_MODE_ACCEPT_MOVING_WRITE_BUFFER |
	                          SSL_MODE_ENABLE_PARTIAL_WRITE);
	/* A server that closes without close_notify (it dropped us, or
	 * died) ends the stream like a plain close: the protocol's framing
	 * tells a cut message from a whole one. */
	SSL_CTX_set_options(ctx, SSL_OP_IGNORE_UNEXPECTED_EOF);
	if (ca_file) {
		if (SSL_CTX_load_verify_locations(ctx, ca_file, NULL) != 1) {
			ssl_reason(why, sizeof(why));
			return bc__client_fail(c, BC_EINVAL,
			                       "TLS: cannot load CA file %s: "
			                       "%s",
			                       ca_file, why);
		}
	} else if (SSL_CTX_set_default_verify_paths(ctx) != 1) {
		ssl_reason(why, sizeof(why));
		return bc__client_fail(c, BC_EIO,
		                       "TLS: cannot load the system's trusted "
		                       "certificates: %s",
		                       why);
	}
	SSL_CTX_set_verify(ctx, insecure ? SSL_VERIFY_NONE : SSL_VERIFY_PEER,
	                   NULL);
	if (!(ssl = SSL_new(ctx))) {
		ssl_reason(why, sizeof(why));
		return bc__client_fail(c, BC_ENOMEM, "TLS: %s", why);
	}
	c->ssl = ssl;
	if (!insecure) {
		X509_VERIFY_PARAM *vp = SSL_get0_param(ssl);
		X509_VERIFY_PARAM_set_hostflags(
		    vp, X509_CHECK_FLAG_NO_PARTIAL_WILDCARDS);
		if (is_ip ? X509_VERIFY_PARAM_set1_ip_asc(vp, host) != 1
		          : X509_VERIFY_PARAM_set1_host(vp, host, 0) != 1) {
			ssl_reason(why, sizeof(why));
			return bc__client_fail(
			    c, BC_EINVAL, "TLS: bad host %s: %s", host, why);
		}
	}
	/* Server Name Indication: a name, never an address (RFC 6066). */
	if (!is_ip) {
		SSL_set_tlsext_host_name(ssl, host);
	}
	if (SSL_set_fd(ssl, c->fd) != 1) {
		ssl_reason(why, sizeof(why));
		return bc__client_fail(c, BC_EIO, "TLS: %s", why);
	}
	for (;;) {
		int n, err, k;
		struct pipe_guard g;
		errno = 0;
		pipe_block(&g);
		n = SSL_connect(ssl);
		pipe_unblock(&g);
		if (n == 1) {
			break;
		}
		err = SSL_get_error(ssl, n);
		if (err == SSL_ERROR_WANT_READ || err == SSL_ERROR_WANT_WRITE) {
			k = wait_fd(c->fd,
			            err == SSL_ERROR_WANT_READ ? POLLIN
			                                       : POLLOUT,
			            deadline);
			if (k == 0) {
				return bc__client_fail(
				    c, BC_ETIMEOUT,
				    "TLS handshake with %s: no answer "
				    "within %d ms",
				    host, c->timeout_ms);
			}
			if (k < 0) {
				return bc__client_fail(c, BC_EIO, "poll: %s",
				                       strerror(errno));
			}
			continue;
		}
		if (SSL_get_verify_result(ssl) != X509_V_OK) {
			long v = SSL_get_verify_result(ssl);
			ERR_clear_error();
			return bc__client_fail(
			    c, BC_EAUTH,
			    "TLS: the certificate of %s is not trusted: "
			    "%s%s",
			    host, X509_verify_cert_error_string(v),
			    ca_file ? "" : " (a private CA: --ca FILE)");
		}
		ssl_reason(why, sizeof(why));
		return bc__client_fail(c, BC_EIO,
		                       "TLS handshake with %s failed: %s (does "
		                       "that port speak TLS?)",
		                       host, why);
	}
	return 0;
}

void bc__client_transport_free(struct bc_client *c)
{
	if (c->ssl) {
		/* A close_notify, best effort: the socket is non-blocking. */
		struct pipe_guard g;
		pipe_block(&g);
		(void)SSL_shutdown(c->ssl);
		pipe_unblock(&g);
		SSL_free(c->ssl);
		c->ssl = NULL;
	}
	SSL_CTX_free(c->ssl_ctx);
	c->ssl_ctx = NULL;
	ERR_clear_error();
}

long bc__client_stream_read(struct bc_client *c, void *buf, size_t cap,
                            double deadline)
{
	for (;;) {
		ssize_t n;
		int k;
		if (c->ssl) {
			struct pipe_guard g;
			int r, err;
			errno = 0;
			/* A read may write (a TLS 1.3 key update answer). */
			pipe_block(&g);
			r = SSL_read(c->ssl, buf,
			             cap > INT32_MAX ? INT32_MAX : (int)cap);
			pipe_unblock(&g);
			if (r > 0) {
				return r;
			}
			err = SSL_get_error(c->ssl, r);
			if (err == SSL_ERROR_ZERO_RETURN ||
			    (err == SSL_ERROR_SSL &&
			     ERR_GET_REASON(ERR_peek_last_error()) ==
			         SSL_R_UNEXPECTED_EOF_WHILE_READING)) {
				ERR_clear_error();
				return BC__CLIENT_EOF;
			}
			if (err == SSL_ERROR_WANT_READ ||
			    err == SSL_ERROR_WANT_WRITE) {
				k = wait_fd(c->fd,
				            err == SSL_ERROR_WANT_READ
				                ? POLLIN
				                : POLLOUT,
				            deadline);
				if (k == 0) {
					return 0;
				}
				if (k < 0) {
					return bc__client_fail(c, BC_EIO,
					                       "poll: %s",
					                       strerror(errno));
				}
				continue;
			}
			if (err == SSL_ERROR_SYSCALL && errno == ECONNRESET) {
				ERR_clear_error();
				return bc__client_fail(
				    c, BC_ECLOSED,
				    "the server reset the connection");
			}
			{
				char why[256];
				ssl_reason(why, sizeof(why));
				return bc__client_fail(c, BC_EIO, "TLS: %s",
				                       why);
			}
		}
		k = wait_fd(c->fd, POLLIN, deadline);
		if (k < 0) {
			return bc__client_fail(c, BC_EIO, "poll: %s",
			                       strerror(errno));
		}
		if (k == 0) {
			return 0;
		}
		n = read(c->fd, buf, cap);
		if (n > 0) {
			return (long)n;
		}
		if (n == 0) {
			return BC__CLIENT_EOF;
		}
		if (errno == EINTR || errno == EAGAIN || errno == EWOULDBLOCK) {
			continue;
		}
		if (errno == ECONNRESET) {
			return bc__client_fail(
			    c, BC_ECLOSED, "the server reset the connection");
		}
		return bc__client_fail(c, BC_EIO, "read: %s", strerror(errno));
	}
}

int bc__client_stream_write(struct bc_client *c, const void *data, size_t len,
                            double deadline, const char *what)
{
	size_t done = 0;
	while (done < len) {
		short want = POLLOUT;
		int k;
		if (c->ssl) {
			size_t left = len - done;
			struct pipe_guard g;
			int r, err;
			errno = 0;
			pipe_block(&g);
			r = SSL_write(c->ssl, (const uint8_t *)data + done,
			              left > INT32_MAX ? INT32_MAX : (int)left);
			pipe_unblock(&g);
			if (r > 0) {
				done += (size_t)r;
				continue;
			}
			err = SSL_get_error(c->ssl, r);
			if (err == SSL_ERROR_WANT_READ) {
				want = POLLIN;
			} else if (err != SSL_ERROR_WANT_WRITE) {
				char why[256];
				if (err == SSL_ERROR_SYSCALL &&
				    (errno == EPIPE || errno == ECONNRESET)) {
					ERR_clear_error();
					return bc__client_fail(
					    c, BC_ECLOSED,
					    "the server closed the "
					    "connection");
				}
				ssl_reason(why, sizeof(why));
				return bc__client_fail(c, BC_EIO, "TLS: %s",
				                       why);
			}
		} else {
			ssize_t n = send(c->fd, (const uint8_t *)data + done,
			                 len - done, MSG_NOSIGNAL);
			if (n > 0) {
				done += (size_t)n;
				continue;
			}
			if (n < 0 && errno == EINTR) {
				continue;
			}
			if (n < 0 && (errno == EPIPE || errno == ECONNRESET)) {
				return bc__client_fail(c, BC_ECLOSED,
				                       "the server closed the "
				                       "connection");
			}
			if (!(n < 0 &&
			      (errno == EAGAIN || errno == EWOULDBLOCK))) {
				return bc__client_fail(c, BC_EIO, "send: %s",
				                       n < 0 ? strerror(errno)
				                             : "wrote nothing");
			}
		}
		if (bc__client_ms_left(deadline) == 0) {
			return bc__client_fail(c, BC_ETIMEOUT,
			                       "%s: %zu of %zu bytes sent when "
			                       "the %d ms timeout passed",
			                       what, done, len, c->timeout_ms);
		}
		k = wait_fd(c->fd, want, deadline);
		if (k < 0 && errno != EINTR) {
			return bc__client_fail(c, BC_EIO, "poll: %s",
			                       strerror(errno));
		}
	}
	return 0;
}
