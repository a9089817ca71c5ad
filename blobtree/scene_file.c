/*
 * Binary scene files (see blobcast/scene.h): a checksummed header before
 * the binary encoding, and the reader that takes a scene file in either
 * form by its first bytes.
 */
#include "blobcast/scene.h"

#include <errno.h>
#include <fcntl.h>
#include <string.h>
#include <unistd.h>
#include <zlib.h>

#include "blobcast/alloc.h"
#include "blobcast/bytes.h"
#include "blobcast/io.h"
#include "file_impl.h"

/* zlib's CRC32 over any length (crc32() takes an unsigned int at a
 * time). */
static uint32_t crc_of(const uint8_t *p, size_t len)
{
	uLong c = crc32(0L, Z_NULL, 0);
	while (len > 0) {
		uInt k = len > (1u << 30) ? (1u << 30) : (uInt)len;
		c = crc32(c, p, k);
		p += k;
		len -= k;
	}
	return (uint32_t)c;
}

/* A scene file's header: magic, the scene's length and its CRC32. */
static void put_header(uint8_t *h, uint32_t len, uint32_t crc)
{
	memcpy(h, BC_SCENE_FILE_MAGIC, 4);
	bc_put_le32(h + 4, len);
	bc_put_le32(h + 8, crc);
}

int bc_scene_file_encode(const struct bc_tree *t, const struct bc_camera *cam,
                         uint8_t **out, size_t *len)
{
	size_t n;
	int rc = bc_scene_encode_after(t, cam, BC_SCENE_FILE_HEADER, out, len);
	if (rc) {
		return rc;
	}
	n = *len - BC_SCENE_FILE_HEADER;
	if (n > BC_SCENE_FILE_MAX_BYTES) {
		bc_free(*out);
		*out = NULL;
		*len = 0;
		return BC_ELIMIT;
	}
	put_header(*out, (uint32_t)n, crc_of(*out + BC_SCENE_FILE_HEADER, n));
	return 0;
}

int bc_scene_file_decode(const uint8_t *buf, size_t len, struct bc_tree *t,
                         struct bc_camera *cam, struct bc_errinfo *ei)
{
	uint32_t n;
	if (cam) {
		bc_camera_default(cam);
	}
	bc_tree_begin(t);
	if (len < 4 || memcmp(buf, BC_SCENE_FILE_MAGIC, 4) != 0) {
		return bc_errinfo_set(ei, BC_EPARSE,
		                      "not a binary scene file (no \"%s\" "
		                      "header)",
		                      BC_SCENE_FILE_MAGIC);
	}
	if (len < BC_SCENE_FILE_HEADER) {
		return bc_errinfo_set(ei, BC_EPARSE,
		                      "cut short: %zu bytes, less than its "
		                      "%u-byte header",
		                      len, BC_SCENE_FILE_HEADER);
	}
	n = bc_get_le32(buf + 4);
	if (n > BC_SCENE_FILE_MAX_BYTES || n != len - BC_SCENE_FILE_HEADER) {
		return bc_errinfo_set(ei, BC_EPARSE,
		                      "%zu bytes after the header, which says "
		                      "%u: the file is cut short or damaged",
		                      len - BC_SCENE_FILE_HEADER, n);
	}
	if (crc_of(buf + BC_SCENE_FILE_HEADER, n) != bc_get_le32(buf + 8)) {
		return bc_errinfo_set(ei, BC_EPARSE,
		                      "damaged: its checksum does not match "
		                      "its bytes");
	}
	return bc_scene_decode(buf + BC_SCENE_FILE_HEADER, n, t, cam, NULL, ei);
}

/* The file's bytes after its header, as the encoder hands them: counted
 * and summed for the header. */
struct file_sink {
	int fd;
	uLong crc;
	uint64_t len;
};

static int file_put(void *ctx, const void *bytes, size_t len)
{
	struct file_sink *f = ctx;
	if (len > BC_SCENE_FILE_MAX_BYTES - f->len) {
		return BC_ELIMIT;
	}
	f->len += len;
	f->crc = crc32(f->crc, bytes, (uInt)len);
	return bc_write_all(f->fd, bytes, len) ? 0 : BC_EIO;
}

int bc_scene_file_write_fd(int fd, const struct bc_tree *t,
                           const struct bc_camera *cam)
{
	struct file_sink f = {fd, crc32(0L, Z_NULL, 0), 0};
	uint8_t head[BC_SCENE_FILE_HEADER] = {0};
	int rc;
	if (bc_tree_root(t) == 0) {
		return BC_EINVAL;
	}
	/* Room for the header, written once the length and sum are known. */
	if (!bc_write_all(fd, head, sizeof(head))) {
		return BC_EIO;
	}
	if ((rc = bc_scene_write_binary(t, cam, file_put, &f))) {
		return rc;
	}
	put_header(head, (uint32_t)f.len, (uint32_t)f.crc);
	if (pwrite(fd, head, sizeof(head), 0) != (ssize_t)sizeof(head)) {
		if (errno == 0) {
			errno = EIO;
		}
		return BC_EIO;
	}
	return 0;
}

struct scene_ref {
	const struct bc_tree *t;
	const struct bc_camera *cam;
};

static int fill_file(int fd, void *ctx)
{
	const struct scene_ref *r = ctx;
	return bc_scene_file_write_fd(fd, r->t, r->cam);
}

int bc_scene_save_binary(const char *path, const struct bc_tree *t,
                         const struct bc_camera *cam, struct bc_errinfo *ei)
{
	if (bc_tree_root(t) == 0) {
		return bc_errinfo_set(ei, BC_EINVAL, "%s: empty scene", path);
	}
	return bc__save_atomic(path, fill_file, &(struct scene_ref){t, cam},
	                       ei);
}

int bc_scene_load_binary(const char *path, struct bc_tree *t,
                         struct bc_camera *cam, struct bc_errinfo *ei)
{
	struct bc_errinfo dei = {0};
	char *buf;
	size_t len;
	int rc;
	if (cam) {
		bc_camera_default(cam);
	}
	bc_tree_begin(t);
	if ((rc = bc__read_file(
	         path, (size_t)BC_SCENE_FILE_MAX_BYTES + BC_SCENE_FILE_HEADER,
	         &buf, &len, ei))) {
		return rc;
	}
	if ((rc = bc_scene_file_decode((const uint8_t *)buf, len, t, cam,
	                               &dei))) {
		rc = bc_errinfo_set(ei, rc, "%s: %s", path, dei.msg);
	}
	bc_free(buf);
	return rc;
}

int bc_scene_load_file(const char *path, struct bc_tree *t,
                       struct bc_camera *cam, struct bc_errinfo *ei)
{
	char head[4];
	bool binary = false;
	int fd = open(path, O_RDONLY | O_CLOEXEC);
	if (fd >= 0) {
		binary = bc_read_all(fd, head, sizeof(head)) &&
		         memcmp(head, BC_SCENE_FILE_MAGIC, 4) == 0;
		close(fd);
	}
	/* (A file that cannot be opened: the JSON reader says why.) */
	return binary ? bc_scene_load_binary(path, t, cam, ei)
	              : bc_scene_load_json(path, t, cam, ei);
}
