/*
 * The daemon's configuration (main.c reads it from the command line and
 * the --config file): plain data, read by the layers that need it.
 */
#ifndef BLOBCAST_SERVER_CONFIG_H
#define BLOBCAST_SERVER_CONFIG_H

#include <stdbool.h>
#include <stdint.h>

#include "blobcast/proto.h"
#include "blobcast/render.h"
#include "blobcast/video.h"

struct bc_token {
	char *token;
	enum bc_proto_role role; /* the highest role it grants */
};

struct bc_srv_config {
	char *listen; /* HOST:PORT, NULL = none */
	char *unix_path;
	char *data_dir;
	enum bc_backend backend;
	char *gl_platform;
	char *server_id;
	struct bc_token *tokens;
	uint32_t ntokens;
	enum bc_simd simd;
	/* H.264 views: the encoder, and libx264's preset (a static string;
	 * NULL: the video module's default). */
	enum bc_video_backend video_encoder;
	const char *x264_preset;
	bool no_damage; /* edits re-render whole views (for comparison) */
	bool no_pace;   /* frames not held for the link (net.c; to compare) */
	uint32_t frame_budget_ms;    /* 0: BC_SRV_FRAME_BUDGET_MS */
	uint32_t render_threads;     /* 0: one per core */
	uint32_t view_cache_mib;     /* 0: BC_SRV_VIEW_BYTES */
	uint32_t max_scene_mib;      /* 0: BC_SRV_MAX_SCENE_BYTES */
	uint32_t client_queue_mib;   /* 0: BC_SRV_MAX_CLIENT_QUEUE */
	uint32_t render_idle_s;      /* 0: BC_SRV_RENDER_IDLE_MS */
	uint32_t scene_memory_mib;   /* 0: half of memory_limit() */
	uint32_t message_timeout_ms; /* 0: BC_SRV_MESSAGE_TIMEOUT_MS */
	uint32_t idle_timeout_ms;    /* 0: BC_SRV_IDLE_TIMEOUT_MS */
	char *tls_cert, *tls_key;    /* PEM files: TLS on the TCP listener */
	bool allow_plaintext;   /* tokens may cross a non-loopback plain TCP */
	bool tls_allow_expired; /* start with an out-of-date certificate */
};

#endif
