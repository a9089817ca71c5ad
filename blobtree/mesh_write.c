/*
 * Mesh files (blobcast/mesh.h): OBJ (text, vertex colours as three extra
 * numbers), PLY (binary little endian, uchar colours), STL (binary, facet
 * normals, no colours) and binary glTF 2.0 (.glb: positions with their
 * min and max, unit vertex normals, COLOR_0 as normalized unsigned bytes,
 * uint32 indices; the JSON chunk made with jansson). Every file is written
 * beside its target and renamed over it, so a reader never sees half a
 * file.
 */
#define _GNU_SOURCE /* fopencookie */
#include "mesh_impl.h"

#include <errno.h>
#include <jansson.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <unistd.h>

#include "blobcast/alloc.h"

static const char *const format_names[BC_MESH_FORMAT_COUNT] = {
    [BC_MESH_FORMAT_OBJ] = "obj",
    [BC_MESH_FORMAT_PLY] = "ply",
    [BC_MESH_FORMAT_STL] = "stl",
    [BC_MESH_FORMAT_GLB] = "glb",
};

enum bc_mesh_format bc_mesh_format_named(const char *name)
{
	for (int f = BC_MESH_FORMAT_INVALID + 1;
	     name && f < BC_MESH_FORMAT_COUNT; f++) {
		if (strcasecmp(name, format_names[f]) == 0) {
			return (enum bc_mesh_format)f;
		}
	}
	return BC_MESH_FORMAT_INVALID;
}

enum bc_mesh_format bc_mesh_format_of(const char *path)
{
	const char *dot = path ? strrchr(path, '.') : NULL;
	return dot ? bc_mesh_format_named(dot + 1) : BC_MESH_FORMAT_INVALID;
}

static void put_f32(FILE *f, float v)
{
	uint32_t u;
	uint8_t b[4];
	memcpy(&u, &v, 4);
	for (int i = 0; i < 4; i++) {
		b[i] = (uint8_t)(u >> (8 * i));
	}
	fwrite(b, 1, 4, f);
}

static void put_u32(FILE *f, uint32_t u)
{
	uint8_t b[4];
	for (int i = 0; i < 4; i++) {
		b[i] = (uint8_t)(u >> (8 * i));
	}
	fwrite(b, 1, 4, f);
}

/* The unit normal of triangle i scaled by twice its area (the cross product
 * of two of its sides). */
static void tri_normal(const struct bc_mesh *m, uint32_t i, double n[3])
{
	bc_mesh_cross3(m->pos[m->tri[i][0]], m->pos[m->tri[i][1]],
	               m->pos[m->tri[i][2]], n);
}

static void write_obj(const struct bc_mesh *m, FILE *f)
{
	fprintf(f, "# blobcast mesh: %u vertices, %u triangles\n", m->nverts,
	        m->ntris);
	for (uint32_t i = 0; i < m->nverts; i++) {
		fprintf(f, "v %.9g %.9g %.9g %.4g %.4g %.4g\n",
		        (double)m->pos[i][0], (double)m->pos[i][1],
		        (double)m->pos[i][2], m->rgb[i][0] / 255.0,
		        m->rgb[i][1] / 255.0, m->rgb[i][2] / 255.0);
	}
	for (uint32_t i = 0; i < m->ntris; i++) {
		fprintf(f, "f %u %u %u\n", m->tri[i][0] + 1, m->tri[i][1] + 1,
		        m->tri[i][2] + 1);
	}
}

static void write_ply(const struct bc_mesh *m, FILE *f)
{
	fprintf(f,
	        "ply\nformat binary_little_endian 1.0\n"
	        "comment blobcast mesh\n"
	        "element vertex %u\nproperty float x\nproperty float y\n"
	        "property float z\nproperty uchar red\n"
	        "property uchar green\nproperty uchar blue\n"
	        "element face %u\nproperty list uchar uint "
	        "vertex_indices\nend_header\n",
	        m->nverts, m->ntris);
	for (uint32_t i = 0; i < m->nverts; i++) {
		for (int a = 0; a < 3; a++) {
			put_f32(f, m->pos[i][a]);
		}
		fwrite(m->rgb[i], 1, 3, f);
	}
	for (uint32_t i = 0; i < m->ntris; i++) {
		fputc(3, f);
		for (int a = 0; a < 3; a++) {
			put_u32(f, m->tri[i][a]);
		}
	}
}

static void write_stl(const struct bc_mesh *m, FILE *f)
{
	char head[80];
	memset(head, 0, sizeof(head));
	snprintf(head, sizeof(head), "blobcast mesh");
	fwrite(head, 1, sizeof(head), f);
	put_u32(f, m->ntris);
	for (uint32_t i = 0; i < m->ntris; i++) {
		double n[3], len;
		tri_normal(m, i, n);
		len = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
		for (int x = 0; x < 3; x++) {
			put_f32(f, len > 0.0 ? (float)(n[x] / len) : 0.0f);
		}
		for (int k = 0; k < 3; k++) {
			for (int x = 0; x < 3; x++) {
				put_f32(f, m->pos[m->tri[i][k]][x]);
			}
		}
		fputc(0, f);
		fputc(0, f);
	}
}

/* ---- glTF 2.0, binary container ------------------------------------------ */

#define GLB_MAGIC 0x46546C67u /* "glTF" */
#define GLB_JSON 0x4E4F534Au  /* "JSON" */
#define GLB_BIN 0x004E4942u   /* "BIN\0" */
#define GL_FLOAT 5126
#define GL_UNSIGNED_BYTE 5121
#define GL_UNSIGNED_INT 5125
#define GL_ARRAY_BUFFER 34962
#define GL_ELEMENT_ARRAY_BUFFER 34963

static int add(json_t *arr, json_t *v)
{
	return json_array_append_new(arr, v);
}

/* The glTF document for m, whose BIN chunk holds, in this order and each a
 * multiple of 4 bytes: positions, normals (float VEC3), colours (ubyte
 * VEC4) and indices (uint32). NULL when out of memory. */
static json_t *gltf_doc(const struct bc_mesh *m, uint64_t bin_len)
{
	uint64_t nv = m->nverts,
	         sz[4] = {12 * nv, 12 * nv, 4 * nv, 12 * (uint64_t)m->ntris};
	json_t *doc = json_object(), *views = json_array(), *acc = json_array();
	json_t *lo = json_array(), *hi = json_array();
	uint64_t off = 0;
	float mn[3], mx[3];
	int bad = !doc || !views || !acc || !lo || !hi;
	for (int a = 0; a < 3; a++) {
		mn[a] = mx[a] = m->pos[0][a];
	}
	for (uint32_t i = 1; i < m->nverts; i++) {
		for (int a = 0; a < 3; a++) {
			mn[a] = fminf(mn[a], m->pos[i][a]);
			mx[a] = fmaxf(mx[a], m->pos[i][a]);
		}
	}
	for (int a = 0; a < 3 && !bad; a++) {
		bad |= add(lo, json_real(mn[a])) || add(hi, json_real(mx[a]));
	}
	for (int v = 0; v < 4 && !bad; v++) {
		bad |= add(views,
		           json_pack("{s:i, s:I, s:I, s:i}", "buffer", 0,
		                     "byteOffset", (json_int_t)off,
		                     "byteLength", (json_int_t)sz[v], "target",
		                     v == 3 ? GL_ELEMENT_ARRAY_BUFFER
		                            : GL_ARRAY_BUFFER));
		off += sz[v];
	}
	if (!bad) {
		bad |=
		    add(acc, json_pack("{s:i, s:i, s:I, s:s, s:O, s:O}",
		                       "bufferView", 0, "componentType",
		                       GL_FLOAT, "count", (json_int_t)nv,
		                       "type", "VEC3", "min", lo, "max", hi)) ||
		    add(acc, json_pack("{s:i, s:i, s:I, s:s}", "bufferView", 1,
		                       "componentType", GL_FLOAT, "count",
		                       (json_int_t)nv, "type", "VEC3")) ||
		    add(acc,
		        json_pack("{s:i, s:i, s:b, s:I, s:s}", "bufferView", 2,
		                  "componentType", GL_UNSIGNED_BYTE,
		                  "normalized", 1, "count", (json_int_t)nv,
		                  "type", "VEC4")) ||
		    add(acc, json_pack("{s:i, s:i, s:I, s:s}", "bufferView", 3,
		                       "componentType", GL_UNSIGNED_INT,
		                       "count", (json_int_t)(3 * m->ntris),
		                       "type", "SCALAR"));
	}
	bad = bad ||
	      json_object_set_new(doc, "asset",
	                          json_pack("{s:s, s:s}", "version", "2.0",
	                                    "generator", "blobcast mesh")) ||
	      json_object_set_new(doc, "scene", json_integer(0)) ||
	      json_object_set_new(doc, "scenes",
	                          json_pack("[{s:[i]}]", "nodes", 0)) ||
	      json_object_set_new(
	          doc, "nodes",
	          json_pack("[{s:i, s:s}]", "mesh", 0, "name", "blobcast")) ||
	      json_object_set_new(doc, "materials",
	                          json_pack("[{s:{s:[f, f, f, f], s:f, s:f}}]",
	                                    "pbrMetallicRoughness",
	                                    "baseColorFactor", 1.0, 1.0, 1.0,
	                                    1.0, "metallicFactor", 0.0,
	                                    "roughnessFactor", 0.6)) ||
	      json_object_set_new(
	          doc, "meshes",
	          json_pack("[{s:[{s:{s:i, s:i, s:i}, s:i, s:i, s:i}]}]",
	                    "primitives", "attributes", "POSITION", 0, "NORMAL",
	                    1, "COLOR_0", 2, "indices", 3, "material", 0,
	                    "mode", 4)) ||
	      json_object_set_new(
	          doc, "buffers",
	          json_pack("[{s:I}]", "byteLength", (json_int_t)bin_len)) ||
	      json_object_set(doc, "bufferViews", views) ||
	      json_object_set(doc, "accessors", acc);
	json_decref(views);
	json_decref(acc);
	json_decref(lo);
	json_decref(hi);
	if (bad) {
		json_decref(doc);
		return NULL;
	}
	return doc;
}

/* Area-weighted vertex normals, unit length ((0, 0, 1) for a vertex whose
 * triangles' normals cancel, which a closed mesh of non-degenerate
 * triangles does not have). NULL when out of memory. */
static float (*vertex_normals(const struct bc_mesh *m))[3]
{
	double(*acc)[3] = bc_calloc(m->nverts, sizeof(*acc));
	float(*out)[3] = bc_malloc((size_t)m->nverts * sizeof(*out));
	if (!acc || !out) {
		bc_free(acc);
		bc_free(out);
		return NULL;
	}
	for (uint32_t i = 0; i < m->ntris; i++) {
		double n[3];
		tri_normal(m, i, n);
		for (int k = 0; k < 3; k++) {
			for (int x = 0; x < 3; x++) {
				acc[m->tri[i][k]][x] += n[x];
			}
		}
	}
	for (uint32_t i = 0; i < m->nverts; i++) {
		double len =
		    sqrt(acc[i][0] * acc[i][0] + acc[i][1] * acc[i][1] +
		         acc[i][2] * acc[i][2]);
		for (int x = 0; x < 3; x++) {
			out[i][x] = len > 0.0 ? (float)(acc[i][x] / len)
			                      : (x == 2 ? 1.0f : 0.0f);
		}
	}
	bc_free(acc);
	return out;
}

static int write_glb(const struct bc_mesh *m, FILE *f, struct bc_errinfo *ei)
{
	uint64_t bin_len = 28ull * m->nverts + 12ull * m->ntris, total;
	json_t *doc;
	char *text;
	size_t jlen, jpad;
	float(*nrm)[3];
	if (m->nverts == 0 || m->ntris == 0) {
		/* glTF has no empty accessor: nothing to put in a mesh. */
		return bc_errinfo_set(ei, BC_EINVAL,
		                      "mesh: no surface in the box, nothing "
		                      "to write as glTF");
	}
	if (!(doc = gltf_doc(m, bin_len))) {
		return bc_errinfo_set(ei, BC_ENOMEM, "mesh: out of memory");
	}
	text = json_dumps(doc, JSON_COMPACT | JSON_REAL_PRECISION(9));
	json_decref(doc);
	if (!text) {
		return bc_errinfo_set(ei, BC_ENOMEM, "mesh: out of memory");
	}
	jlen = strlen(text);
	jpad = (4 - jlen % 4) % 4;
	total = 12 + 8 + jlen + jpad + 8 + bin_len;
	if (total > UINT32_MAX) {
		free(text);
		return bc_errinfo_set(
		    ei, BC_ERANGE,
		    "mesh: %u vertices and %u triangles are "
		    "more than a .glb holds (4 GiB); use .ply "
		    "or a lower --resolution",
		    m->nverts, m->ntris);
	}
	if (!(nrm = vertex_normals(m))) {
		free(text);
		return bc_errinfo_set(ei, BC_ENOMEM, "mesh: out of memory");
	}
	put_u32(f, GLB_MAGIC);
	put_u32(f, 2);
	put_u32(f, (uint32_t)total);
	/* The JSON chunk, padded with spaces to 4 bytes. */
	put_u32(f, (uint32_t)(jlen + jpad));
	put_u32(f, GLB_JSON);
	fwrite(text, 1, jlen, f);
	fwrite("   ", 1, jpad, f);
	free(text);
	/* The BIN chunk: every part is a multiple of 4 bytes already. */
	put_u32(f, (uint32_t)bin_len);
	put_u32(f, GLB_BIN);
	for (uint32_t i = 0; i < m->nverts; i++) {
		for (int a = 0; a < 3; a++) {
			put_f32(f, m->pos[i][a]);
		}
	}
	for (uint32_t i = 0; i < m->nverts; i++) {
		for (int a = 0; a < 3; a++) {
			put_f32(f, nrm[i][a]);
		}
	}
	for (uint32_t i = 0; i < m->nverts; i++) {
		fwrite(m->rgb[i], 1, 3, f);
		fputc(255, f);
	}
	for (uint32_t i = 0; i < m->ntris; i++) {
		for (int a = 0; a < 3; a++) {
			put_u32(f, m->tri[i][a]);
		}
	}
	bc_free(nrm);
	return 0;
}

/* Writes m to f in format (checked by the caller). */
static int write_format(const struct bc_mesh *m, FILE *f,
                        enum bc_mesh_format format, struct bc_errinfo *ei)
{
	switch (format) {
	case BC_MESH_FORMAT_OBJ:
		write_obj(m, f);
		return 0;
	case BC_MESH_FORMAT_PLY:
		write_ply(m, f);
		return 0;
	case BC_MESH_FORMAT_STL:
		write_stl(m, f);
		return 0;
	default:
		return write_glb(m, f, ei);
	}
}

static int check_format(enum bc_mesh_format format, struct bc_errinfo *ei)
{
	if (format <= BC_MESH_FORMAT_INVALID ||
	    format >= BC_MESH_FORMAT_COUNT) {
		return bc_errinfo_set(ei, BC_EINVAL, "mesh: unknown format");
	}
	return 0;
}

/* Writes path atomically: a temporary file beside it, filled by fill(f,
 * arg), flushed to disk and renamed over it; nothing is left on failure. */
static int write_atomic(const char *path,
                        int (*fill)(FILE *f, const void *arg,
                                    struct bc_errinfo *ei),
                        const void *arg, struct bc_errinfo *ei)
{
	size_t plen = path ? strlen(path) : 0;
	char *tmp;
	FILE *f;
	int rc;
	if (!path || !plen) {
		return bc_errinfo_set(ei, BC_EINVAL, "mesh: no file name");
	}
	tmp = bc_malloc(plen + 48);
	if (!tmp) {
		return bc_errinfo_set(ei, BC_ENOMEM, "mesh: out of memory");
	}
	/* Beside the target, so that rename() replaces it in one step. */
	snprintf(tmp, plen + 48, "%s.tmp.%ld", path, (long)getpid());
	f = fopen(tmp, "wb");
	if (!f) {
		rc = bc_errinfo_set(ei, BC_EIO, "%s: %s", tmp, strerror(errno));
		bc_free(tmp);
		return rc;
	}
	rc = fill(f, arg, ei);
	if (rc == 0 && (fflush(f) != 0 || ferror(f) || fsync(fileno(f)) != 0)) {
		rc = bc_errinfo_set(ei, BC_EIO, "%s: %s", tmp, strerror(errno));
	}
	if (fclose(f) != 0 && rc == 0) {
		rc = bc_errinfo_set(ei, BC_EIO, "%s: %s", tmp, strerror(errno));
	}
	if (rc == 0 && rename(tmp, path) != 0) {
		rc =
		    bc_errinfo_set(ei, BC_EIO, "%s: %s", path, strerror(errno));
	}
	if (rc) {
		(void)remove(tmp);
	}
	bc_free(tmp);
	return rc;
}

struct mesh_in {
	const struct bc_mesh *m;
	enum bc_mesh_format format;
};

static int fill_mesh(FILE *f, const void *arg, struct bc_errinfo *ei)
{
	const struct mesh_in *in = arg;
	return write_format(in->m, f, in->format, ei);
}

int bc_mesh_write(const struct bc_mesh *m, const char *path,
                  enum bc_mesh_format format, struct bc_errinfo *ei)
{
	struct mesh_in in = {m, format};
	int rc = check_format(format, ei);
	return rc ? rc : write_atomic(path, fill_mesh, &in, ei);
}

struct bytes_in {
	const uint8_t *p;
	size_t len;
};

static int fill_bytes(FILE *f, const void *arg, struct bc_errinfo *ei)
{
	const struct bytes_in *in = arg;
	(void)ei;
	fwrite(in->p, 1, in->len, f); /* ferror() is checked after */
	return 0;
}

int bc_mesh_write_file(const char *path, const uint8_t *bytes, size_t len,
                       struct bc_errinfo *ei)
{
	struct bytes_in in = {bytes, len};
	return write_atomic(path, fill_bytes, &in, ei);
}

/* A stream into memory from bc_malloc, grown as it is written: the
 * caller's buffer itself, head bytes left at its start (open_memstream's
 * would be a second buffer of the file's size, copied after). */
struct membuf {
	uint8_t *p;
	size_t len, cap;
};

static ssize_t membuf_write(void *cookie, const char *buf, size_t n)
{
	struct membuf *b = cookie;
	if (n > b->cap - b->len) {
		size_t cap = b->cap * 2 > b->len + n ? b->cap * 2 : b->len + n;
		uint8_t *p = bc_realloc(b->p, cap);
		if (!p) {
			return -1; /* the stream's error: ferror() */
		}
		b->p = p;
		b->cap = cap;
	}
	memcpy(b->p + b->len, buf, n);
	b->len += n;
	return (ssize_t)n;
}

int bc_mesh_write_mem(const struct bc_mesh *m, enum bc_mesh_format format,
                      size_t head, uint8_t **out, size_t *len,
                      struct bc_errinfo *ei)
{
	struct membuf b = {NULL, head, head + 65536};
	cookie_io_functions_t io = {.write = membuf_write};
	FILE *f;
	int rc;
	*out = NULL;
	*len = 0;
	if ((rc = check_format(format, ei))) {
		return rc;
	}
	if (!(b.p = bc_malloc(b.cap)) || !(f = fopencookie(&b, "w", io))) {
		bc_free(b.p);
		return bc_errinfo_set(ei, BC_ENOMEM, "mesh: out of memory");
	}
	rc = write_format(m, f, format, ei);
	if ((fflush(f) != 0 || ferror(f)) && rc == 0) {
		rc = bc_errinfo_set(ei, BC_ENOMEM, "mesh: out of memory");
	}
	fclose(f);
	if (rc) {
		bc_free(b.p);
		return rc;
	}
	*out = b.p;
	*len = b.len;
	return 0;
}
