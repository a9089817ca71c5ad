/*
 * A libblobcast example (docs/client.md): joins a session, asks for frames,
 * moves one primitive with a key=value edit and waits for the frame that
 * shows the edit.
 *
 *   cc nudge.c $(pkg-config --cflags --libs blobcast) -o nudge
 *   ./nudge 127.0.0.1:7878 default 32 translate=0.2,0,0
 */
#include <stdio.h>
#include <stdlib.h>

#include <blobcast/client.h>

int main(int argc, char **argv)
{
	struct bc_client *c = NULL;
	struct bc_client_image img;
	struct bc_errinfo ei = {0};
	struct bc_msg m;
	uint32_t seq;
	uint64_t order;
	int status = 1;
	if (argc < 5) {
		fprintf(stderr,
		        "usage: nudge ADDR SESSION NODE KEY=VALUE...\n");
		return 2;
	}
	bc_client_image_init(&img);
	if (bc_client_connect(
	        &c, &(struct bc_client_opts){.addr = argv[1], .name = "nudge"},
	        &ei) ||
	    bc_client_join(c, argv[2], BC_PROTO_ROLE_EDITOR,
	                   BC_CLIENT_JOIN_EXISTING, &ei) ||
	    bc_client_view(c,
	                   &(struct bc_msg_view){.width = 320, .height = 240},
	                   NULL, &ei)) {
		fprintf(stderr, "nudge: %s (%s)\n", ei.msg,
		        bc_err_name(ei.code));
		goto out;
	}
	/* The view's picture first: coarse levels, then the still. Waiting
	 * for other messages consumes frames, so the edit starts only once
	 * the picture is whole and final; its frames then come after its
	 * EDIT_APPLIED. */
	do {
		if (bc_client_wait(c, BC_MSG_FRAME, 0, &m, 0, &ei) ||
		    bc_client_image_apply(&img, &m, &ei)) {
			fprintf(stderr, "nudge: %s\n", ei.msg);
			goto out;
		}
	} while (!(m.flags & BC_PROTO_FLAG_STILL));
	if (bc_client_edit_kv(c, (uint32_t)strtoul(argv[3], NULL, 10),
	                      (const char *const *)argv + 4, (size_t)(argc - 4),
	                      false, &seq, &ei) ||
	    bc_client_wait_applied(c, seq, &order, &ei)) {
		fprintf(stderr, "nudge: %s (%s)\n", ei.msg,
		        bc_err_name(ei.code));
		goto out;
	}
	/* Frames arrive in order; the first whose order reaches the edit's
	 * shows it. */
	do {
		if (bc_client_wait(c, BC_MSG_FRAME, 0, &m, 0, &ei) ||
		    bc_client_image_apply(&img, &m, &ei)) {
			fprintf(stderr, "nudge: %s\n", ei.msg);
			goto out;
		}
	} while (img.order < order);
	printf("edit order %llu shown in frame %u (%ux%u, %s)\n",
	       (unsigned long long)order, img.frame_no, img.width, img.height,
	       img.complete ? "complete" : "partial");
	status = 0;
out:
	bc_client_image_finish(&img);
	bc_client_destroy(c);
	return status;
}
