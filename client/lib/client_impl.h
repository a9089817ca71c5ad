/*
 * Private parts of libblobcast shared by its files: the connection struct
 * (client.c), the scene mirror's edit replay (edit.c) and the clock.
 */
#ifndef BLOBCAST_CLIENT_IMPL_H
#define BLOBCAST_CLIENT_IMPL_H

#include <stdbool.h>
#include <stdint.h>

#include "blobcast/client.h"

struct bc_client {
	int fd;
	int err;           /* 0 or the sticky BC_E* code */
	char errstr[256];  /* its reason */
	int timeout_ms;    /* < 0: none */
	uint8_t encodings; /* what our HELLO announced */
	uint32_t next_seq;
	struct bc_proto_reader reader;
	struct bc_proto_buf out;
	uint8_t *chunk; /* BC_CLIENT_READ_CHUNK bytes */
	struct bc_client_info info;
	/* The scene mirror, valid when has_scene. */
	struct bc_tree *scene;
	struct bc_camera camera;
	bool has_scene;
	uint64_t scene_order;
};

/* Milliseconds of a monotonic clock. */
double bc__client_now_ms(void);

/* Replays the operations of an EDIT_APPLIED on a scene mirror, atomically
 * (bc_edit_replay). Returns 0 or the failing operation's error with the
 * reason in ei; *t is then unchanged (the caller drops it). */
int bc__client_replay(struct bc_tree **t, const struct bc_msg_edit_applied *ea,
		      struct bc_errinfo *ei);

#endif
