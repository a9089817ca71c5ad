/*
 * Edits in libblobcast: the key=value syntax and the replay of
 * EDIT_APPLIED on the scene mirror both come from the edit module, the
 * code the daemon applies edits with, so a mirror follows the server's
 * scene exactly.
 */
#include "blobcast/edit.h"
#include "client_impl.h"

int bc_client_edit_parse(const struct bc_tree *scene, uint32_t node,
                         const char *const *kv, size_t n,
                         struct bc_proto_field *fields, uint8_t *nfields,
                         struct bc_errinfo *ei)
{
	return bc_edit_parse_kv(scene, node, kv, n, fields, nfields, ei);
}

int bc__client_replay(struct bc_tree **t, const struct bc_msg_edit_applied *ea,
                      struct bc_errinfo *ei)
{
	return bc_edit_replay(t, ea, ei);
}
