/*
 * TLS for the daemon's TCP connections (see tls.h). OpenSSL reads from and
 * writes to two memory BIOs per connection; net.c moves the bytes between
 * them and the libuv stream, so the loop never blocks on TLS and the
 * connection limits and timeouts stay those of plain connections (the
 * handshake counts as time before HELLO).
 */
#include <stdio.h>
#include <string.h>
#include <time.h>

#include <openssl/bio.h>
#include <openssl/err.h>
#include <openssl/ssl.h>

#include "blobcast/alloc.h"
#include "blobcast/log.h"
#include "srv_limits.h"
#include "tls.h"

struct bc_tls_ctx {
	SSL_CTX *ssl;
};

struct bc_tls {
	SSL *ssl;
	BIO *in;  /* ciphertext from the peer (SSL reads it) */
	BIO *out; /* ciphertext for the peer (SSL writes it) */
	bool ready;
	bool started; /* bytes have come from the peer */
};

/* OpenSSL's most recent error on this thread as text, queue cleared. */
static void ssl_reason(char *buf, size_t len)
{
	unsigned long e = ERR_peek_last_error();
	if (e) {
		ERR_error_string_n(e, buf, len);
	} else {
		snprintf(buf, len, "unknown TLS error");
	}
	ERR_clear_error();
}

/* t as text ("Dec  3 08:00:00 2026 GMT"). */
static void time_text(const ASN1_TIME *t, char *buf, size_t len)
{
	BIO *b = BIO_new(BIO_s_mem());
	int n = 0;
	if (b && ASN1_TIME_print(b, t)) {
		n = BIO_read(b, buf, (int)len - 1);
	}
	buf[n > 0 ? n : 0] = '\0';
	BIO_free(b);
	ERR_clear_error();
}

/* The certificate's dates against the clock (see bc_tls_ctx_new). */
static int check_dates(SSL_CTX *ssl, const char *cert_file, bool allow_expired,
                       struct bc_errinfo *ei)
{
	X509 *x = SSL_CTX_get0_certificate(ssl);
	const ASN1_TIME *from, *until;
	char when[64];
	const char *what = NULL;
	int days = 0, secs = 0;
	if (!x) {
		return 0;
	}
	from = X509_get0_notBefore(x);
	until = X509_get0_notAfter(x);
	if (X509_cmp_current_time(from) > 0) {
		what = "is not valid before";
		time_text(from, when, sizeof(when));
	} else if (X509_cmp_current_time(until) < 0) {
		what = "expired on";
		time_text(until, when, sizeof(when));
	}
	if (what && !allow_expired) {
		return bc_errinfo_set(ei, BC_EINVAL,
		                      "--tls-cert %s: the certificate %s %s, "
		                      "so clients would refuse it: renew it or "
		                      "check the clock (--tls-allow-expired "
		                      "starts anyway)",
		                      cert_file, what, when);
	}
	if (what) {
		bc_log(BC_LOG_WARN,
		       "--tls-cert %s: the certificate %s %s; starting as "
		       "--tls-allow-expired says, but clients that check it "
		       "will refuse to connect",
		       cert_file, what, when);
	} else if (ASN1_TIME_diff(&days, &secs, NULL, until) &&
	           days < BC_SRV_TLS_WARN_DAYS) {
		time_text(until, when, sizeof(when));
		bc_log(BC_LOG_WARN,
		       "--tls-cert %s: the certificate expires in %d day%s "
		       "(%s): renew it, then SIGHUP reloads it",
		       cert_file, days, days == 1 ? "" : "s", when);
	}
	ERR_clear_error();
	return 0;
}

int bc_tls_ctx_new(struct bc_tls_ctx **out, const char *cert_file,
                   const char *key_file, bool allow_expired,
                   struct bc_errinfo *ei)
{
	int rc;
	struct bc_tls_ctx *ctx;
	char why[256];
	*out = NULL;
	ERR_clear_error();
	if (!(ctx = bc_calloc(1, sizeof(*ctx)))) {
		return bc_errinfo_set(ei, BC_ENOMEM, "out of memory");
	}
	ctx->ssl = SSL_CTX_new(TLS_server_method());
	if (!ctx->ssl) {
		ssl_reason(why, sizeof(why));
		bc_free(ctx);
		return bc_errinfo_set(ei, BC_EIO, "TLS: %s", why);
	}
	SSL_CTX_set_min_proto_version(ctx->ssl, TLS1_2_VERSION);
	/* No resumption state to keep per daemon, and no tickets to write
	 * after the handshake: every connection does a full handshake. */
	SSL_CTX_set_session_cache_mode(ctx->ssl, SSL_SESS_CACHE_OFF);
	SSL_CTX_set_num_tickets(ctx->ssl, 0);
	SSL_CTX_set_options(ctx->ssl, SSL_OP_NO_RENEGOTIATION |
	                                  SSL_OP_CIPHER_SERVER_PREFERENCE);
	if (SSL_CTX_use_certificate_chain_file(ctx->ssl, cert_file) != 1) {
		ssl_reason(why, sizeof(why));
		bc_tls_ctx_free(ctx);
		return bc_errinfo_set(ei, BC_EINVAL,
		                      "--tls-cert %s: cannot load the "
		                      "certificate chain (PEM): %s",
		                      cert_file, why);
	}
	if (SSL_CTX_use_PrivateKey_file(ctx->ssl, key_file, SSL_FILETYPE_PEM) !=
	    1) {
		ssl_reason(why, sizeof(why));
		bc_tls_ctx_free(ctx);
		return bc_errinfo_set(ei, BC_EINVAL,
		                      "--tls-key %s: cannot load the private "
		                      "key (PEM): %s",
		                      key_file, why);
	}
	if (SSL_CTX_check_private_key(ctx->ssl) != 1) {
		ssl_reason(why, sizeof(why));
		bc_tls_ctx_free(ctx);
		return bc_errinfo_set(ei, BC_EINVAL,
		                      "--tls-key %s does not belong to the "
		                      "certificate in %s: %s",
		                      key_file, cert_file, why);
	}
	if ((rc = check_dates(ctx->ssl, cert_file, allow_expired, ei))) {
		bc_tls_ctx_free(ctx);
		return rc;
	}
	*out = ctx;
	return 0;
}

uint64_t bc_tls_ctx_not_after_ms(const struct bc_tls_ctx *ctx)
{
	X509 *x = SSL_CTX_get0_certificate(ctx->ssl);
	int days = 0, secs = 0;
	int64_t at;
	/* Its distance from now, added to the clock: no time zone
	 * arithmetic of our own. */
	if (!x || !ASN1_TIME_diff(&days, &secs, NULL, X509_get0_notAfter(x))) {
		ERR_clear_error();
		return 0;
	}
	at = (int64_t)time(NULL) + (int64_t)days * 86400 + secs;
	return at > 0 ? (uint64_t)at * 1000u : 0u;
}

void bc_tls_ctx_free(struct bc_tls_ctx *ctx)
{
	if (ctx) {
		SSL_CTX_free(ctx->ssl);
		bc_free(ctx);
	}
}

struct bc_tls *bc_tls_new(struct bc_tls_ctx *ctx)
{
	struct bc_tls *t = bc_calloc(1, sizeof(*t));
	if (!t) {
		return NULL;
	}
	t->ssl = SSL_new(ctx->ssl);
	t->in = BIO_new(BIO_s_mem());
	t->out = BIO_new(BIO_s_mem());
	if (!t->ssl || !t->in || !t->out) {
		SSL_free(t->ssl);
		BIO_free(t->in);
		BIO_free(t->out);
		bc_free(t);
		ERR_clear_error();
		return NULL;
	}
	/* An empty memory BIO reads as "retry later", not as the end. */
	BIO_set_mem_eof_return(t->in, -1);
	BIO_set_mem_eof_return(t->out, -1);
	SSL_set_bio(t->ssl, t->in, t->out); /* the SSL owns both now */
	SSL_set_accept_state(t->ssl);
	return t;
}

void bc_tls_free(struct bc_tls *t)
{
	if (t) {
		SSL_free(t->ssl);
		bc_free(t);
	}
}

bool bc_tls_ready(const struct bc_tls *t)
{
	return t->ready;
}

bool bc_tls_started(const struct bc_tls *t)
{
	return t->started;
}

int bc_tls_feed(struct bc_tls *t, const void *data, size_t len)
{
	t->started = t->started || len > 0;
	while (len > 0) {
		int chunk = len > (1u << 30) ? (1 << 30) : (int)len;
		int n = BIO_write(t->in, data, chunk);
		if (n <= 0) {
			ERR_clear_error();
			return BC_ENOMEM;
		}
		data = (const uint8_t *)data + n;
		len -= (size_t)n;
	}
	return 0;
}

long bc_tls_read(struct bc_tls *t, void *buf, size_t cap, char *why,
                 size_t whylen)
{
	int n, err;
	ERR_clear_error();
	if (!t->ready) {
		n = SSL_do_handshake(t->ssl);
		if (n != 1) {
			err = SSL_get_error(t->ssl, n);
			if (err == SSL_ERROR_WANT_READ ||
			    err == SSL_ERROR_WANT_WRITE) {
				return 0;
			}
			ssl_reason(why, whylen);
			return BC_EIO;
		}
		t->ready = true;
	}
	n = SSL_read(t->ssl, buf, cap > INT32_MAX ? INT32_MAX : (int)cap);
	if (n > 0) {
		return n;
	}
	err = SSL_get_error(t->ssl, n);
	if (err == SSL_ERROR_WANT_READ || err == SSL_ERROR_WANT_WRITE) {
		return 0;
	}
	if (err == SSL_ERROR_ZERO_RETURN) {
		snprintf(why, whylen, "the peer closed the TLS session");
		ERR_clear_error();
		return BC_ECLOSED;
	}
	ssl_reason(why, whylen);
	return BC_EIO;
}

int bc_tls_write(struct bc_tls *t, const void *data, size_t len)
{
	ERR_clear_error();
	if (!t->ready) {
		return BC_EIO;
	}
	while (len > 0) {
		int chunk = len > (1u << 30) ? (1 << 30) : (int)len;
		/* Memory BIOs take everything: a write never waits. */
		int n = SSL_write(t->ssl, data, chunk);
		if (n <= 0) {
			ERR_clear_error();
			return BC_EIO;
		}
		data = (const uint8_t *)data + n;
		len -= (size_t)n;
	}
	return 0;
}

void bc_tls_close_notify(struct bc_tls *t)
{
	if (t->ready) {
		(void)SSL_shutdown(t->ssl);
		ERR_clear_error();
	}
}

int bc_tls_take_output(struct bc_tls *t, uint8_t **out, size_t *len)
{
	size_t n = BIO_ctrl_pending(t->out);
	*out = NULL;
	*len = 0;
	if (n == 0) {
		return 0;
	}
	if (!(*out = bc_malloc(n))) {
		return BC_ENOMEM;
	}
	if (BIO_read(t->out, *out, (int)n) != (int)n) {
		bc_free(*out);
		*out = NULL;
		ERR_clear_error();
		return BC_EIO;
	}
	*len = n;
	return 0;
}

const char *bc_tls_describe(const struct bc_tls *t, char *buf, size_t len)
{
	snprintf(buf, len, "%s %s", SSL_get_version(t->ssl),
	         SSL_get_cipher_name(t->ssl));
	return buf;
}
