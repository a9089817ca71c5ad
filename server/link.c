/*
 * The shared pieces of link.h: reference-counted frames, the ERROR and
 * OK messages every layer below transport sends, and the heap given back
 * to the system after big frees.
 */
#include "link.h"

#include <stdarg.h>
#include <stdio.h>
#include <string.h>
#if defined(__GLIBC__)
#include <malloc.h>
#endif

#include "blobcast/alloc.h"
#include "blobcast/log.h"

struct bc_shared *bc_shared_new(size_t len)
{
	struct bc_shared *s = bc_malloc(sizeof(*s) + len);
	if (s) {
		s->refs = 1;
		s->needs = 0;
		s->older = NULL;
		s->len = len;
	}
	return s;
}

struct bc_shared *bc_shared_adopt(uint8_t *buf, size_t total)
{
	/* bc_malloc's memory is aligned for any object. */
	struct bc_shared *s = (struct bc_shared *)(void *)buf;
	s->refs = 1;
	s->needs = 0;
	s->older = NULL;
	s->len = total - BC_SHARED_HEAD;
	return s;
}

void bc_shared_unref(struct bc_shared *s)
{
	if (s && --s->refs == 0) {
		bc_shared_unref(s->older);
		bc_free(s);
	}
}

void bc_link_error(const struct bc_link *l, struct bc_conn_ref to, uint32_t seq,
                   int code, bool fatal, const char *fmt, ...)
{
	char text[BC_PROTO_MAX_ERROR_TEXT];
	struct bc_msg m = {.type = BC_MSG_ERROR, .seq = seq};
	va_list args;
	int n;
	va_start(args, fmt);
	n = vsnprintf(text, sizeof(text), fmt, args);
	va_end(args);
	if (n < 0) {
		n = 0;
	}
	m.flags = fatal ? BC_PROTO_FLAG_FATAL : 0;
	m.error.code = (uint16_t)(code < 0 ? -code : code);
	m.error.text.ptr = text;
	m.error.text.len =
	    (uint32_t)((size_t)n < sizeof(text) ? (size_t)n : sizeof(text) - 1);
	bc_log(BC_LOG_INFO, "client %u: error %s: %s", to.gen,
	       bc_err_name(code), text);
	l->send(l->ud, to, &m);
}

void bc_link_ok(const struct bc_link *l, struct bc_conn_ref to, uint32_t seq)
{
	struct bc_msg ok = {.type = BC_MSG_OK, .seq = seq};
	l->send(l->ud, to, &ok);
}

int bc_ops_copy(struct bc_ops_copy *out, const struct bc_proto_edit_op *ops,
                uint32_t n)
{
	size_t blob = 0, at = 0;
	memset(out, 0, sizeof(*out));
	for (uint32_t i = 0; i < n; i++) {
		blob += (size_t)ops[i].nfields * sizeof(*ops[i].fields);
		blob += ops[i].subtree.len + ops[i].name.len;
	}
	if (!(out->ops = bc_calloc(n ? n : 1, sizeof(*ops))) ||
	    (blob && !(out->blob = bc_malloc(blob)))) {
		bc_ops_copy_finish(out);
		return BC_ENOMEM;
	}
	if (n) {
		memcpy(out->ops, ops, (size_t)n * sizeof(*ops));
	}
	/* Every field array first, then the subtree bytes: a subtree of a
	 * length that is no multiple of 4 must not leave the next array
	 * misaligned (the fields hold floats). */
	for (uint32_t i = 0; i < n; i++) {
		struct bc_proto_edit_op *op = &out->ops[i];
		size_t fbytes = (size_t)op->nfields * sizeof(*op->fields);
		if (fbytes) {
			memcpy(out->blob + at, ops[i].fields, fbytes);
			op->fields =
			    (struct bc_proto_field *)(void *)(out->blob + at);
			at += fbytes;
		}
	}
	for (uint32_t i = 0; i < n; i++) {
		struct bc_proto_edit_op *op = &out->ops[i];
		if (op->subtree.len) {
			memcpy(out->blob + at, ops[i].subtree.ptr,
			       op->subtree.len);
			op->subtree.ptr = out->blob + at;
			at += op->subtree.len;
		}
		if (op->name.len) {
			memcpy(out->blob + at, ops[i].name.ptr, op->name.len);
			op->name.ptr = (const char *)out->blob + at;
			at += op->name.len;
		}
	}
	out->n = n;
	out->bytes = (size_t)n * sizeof(*ops) + blob;
	return 0;
}

void bc_ops_copy_finish(struct bc_ops_copy *c)
{
	if (!c) {
		return;
	}
	bc_free(c->ops);
	bc_free(c->blob);
	memset(c, 0, sizeof(*c));
}

void bc_heap_policy(void)
{
#if defined(__GLIBC__)
	mallopt(M_ARENA_MAX, 1);
#endif
}

void bc_heap_give_back(void)
{
#if defined(__GLIBC__)
	malloc_trim(0);
#endif
}
