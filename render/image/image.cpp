/*
 * The OpenImageIO shim behind blobcast/image.h: the only C++ in the project.
 * It owns the mapping from our sample types to OpenImageIO's, the choice of
 * format from the file extension, and turning OpenImageIO's errors (and any
 * exception) into BC_E* codes with a reason. It is built as a module of its
 * own (bc_image_oiio) that image.c loads on first use (image_module.h); the
 * only thing it keeps is the allocator the program lends it.
 */
extern "C" {
#include "blobcast/error.h"
#include "blobcast/image.h"
#include "image_module.h"
}

#include <OpenImageIO/imageio.h>

#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <exception>
#include <memory>
#include <string>

namespace {

const struct bc_image_host *host;

OIIO::TypeDesc oiio_type(enum bc_image_type type)
{
	switch (type) {
	case BC_IMAGE_U8:
		return OIIO::TypeDesc::UINT8;
	case BC_IMAGE_F32:
		return OIIO::TypeDesc::FLOAT;
	case BC_IMAGE_U32:
		return OIIO::TypeDesc::UINT32;
	default:
		return OIIO::TypeDesc::UNKNOWN;
	}
}

size_t sample_size(enum bc_image_type type)
{
	switch (type) {
	case BC_IMAGE_U8:
		return 1;
	case BC_IMAGE_F32:
	case BC_IMAGE_U32:
		return 4;
	default:
		return 0;
	}
}

/* The extension of path, lower case, without the dot ("" when none). */
std::string extension(const char *path)
{
	const char *slash = std::strrchr(path, '/');
	const char *dot = std::strrchr(path, '.');
	std::string ext;
	if (!dot || (slash && dot < slash)) {
		return ext;
	}
	for (const char *c = dot + 1; *c; c++) {
		char ch = *c;
		if (ch >= 'A' && ch <= 'Z') {
			ch = static_cast<char>(ch - 'A' + 'a');
		}
		ext.push_back(ch);
	}
	return ext;
}

/* OpenImageIO's messages may span lines; keep the first one so reasons stay
 * one sentence. */
std::string first_line(std::string s)
{
	size_t nl = s.find('\n');
	if (nl != std::string::npos) {
		s.resize(nl);
	}
	return s.empty() ? std::string("no reason given") : s;
}

/* OpenImageIO 2.4 reads PFM but its pnm writer only emits integer PNM, so
 * the one float format it cannot write is written here: the header
 * "Pf\n<w> <h>\n-1.0\n" (grey, negative scale = little-endian) and rows
 * bottom to top. Reading stays with OpenImageIO. */
int write_pfm(const char *path, const struct bc_image *img,
	      struct bc_errinfo *ei)
{
	const float *v = static_cast<const float *>(img->pixels);
	std::FILE *f = std::fopen(path, "wb");
	bool ok;
	if (!f) {
		return bc_errinfo_set(ei, BC_EIO,
				      "%s: cannot open for writing: %s", path,
				      std::strerror(errno));
	}
	ok = std::fprintf(f, "Pf\n%u %u\n-1.0\n", img->width,
			  img->height) > 0;
	for (uint32_t row = img->height; ok && row-- > 0;) {
		const float *line = v + static_cast<size_t>(row) * img->width;
		/* Every platform we build on is little-endian; the header's
		 * negative scale says so. */
		ok = std::fwrite(line, sizeof(float), img->width, f) ==
		     img->width;
	}
	if (std::fclose(f) != 0) {
		ok = false;
	}
	if (!ok) {
		return bc_errinfo_set(ei, BC_EIO, "%s: write failed", path);
	}
	return 0;
}

/* The time a written file states (TIFF DateTime, EXR capDate): that of
 * SOURCE_DATE_EPOCH when it is set (seconds since 1970, UTC), so that the
 * same scene rendered twice gives the same bytes, as reproducible build
 * tools expect; left to OpenImageIO (the time of writing) when it is not.
 * Returns 0, or BC_EINVAL for a value that is not such a number. */
int source_date(std::string &out, struct bc_errinfo *ei)
{
	const char *v = std::getenv("SOURCE_DATE_EPOCH");
	char *end = nullptr;
	char text[32];
	struct tm tm;
	out.clear();
	if (!v) {
		return 0;
	}
	errno = 0;
	unsigned long long secs = std::strtoull(v, &end, 10);
	/* Up to year 9999: the tag holds four digits of year. */
	if (!*v || *v < '0' || *v > '9' || *end || errno ||
	    secs > 253402300799ull) {
		return bc_errinfo_set(ei, BC_EINVAL,
				      "SOURCE_DATE_EPOCH='%s' is not a count "
				      "of seconds since 1970-01-01 UTC up to "
				      "year 9999; unset it to stamp files with "
				      "the time of writing",
				      v);
	}
	time_t t = static_cast<time_t>(secs);
	if (!gmtime_r(&t, &tm) ||
	    std::strftime(text, sizeof(text), "%Y:%m:%d %H:%M:%S", &tm) != 19) {
		return bc_errinfo_set(ei, BC_EINVAL,
				      "SOURCE_DATE_EPOCH='%s': no date", v);
	}
	out = text;
	return 0;
}

int write_image(const char *path, const struct bc_image *img,
		struct bc_errinfo *ei)
{
	size_t ss = sample_size(img->type);
	std::string ext = extension(path);
	if (!host->ext_supports(path, img->type)) {
		if (img->type == BC_IMAGE_U8) {
			return bc_errinfo_set(ei, BC_ENOTSUP,
					      "%s: no image format for "
					      "extension '.%s'",
					      path, ext.c_str());
		}
		return bc_errinfo_set(ei, BC_EINVAL,
				      "%s: '.%s' cannot hold %s samples "
				      "exactly (use %s)",
				      path, ext.c_str(),
				      img->type == BC_IMAGE_F32 ? "float"
								: "uint32",
				      img->type == BC_IMAGE_F32
					      ? ".exr, .tif or .pfm"
					      : ".tif or .exr");
	}
	if (ext == "pfm") {
		return write_pfm(path, img, ei);
	}
	std::unique_ptr<OIIO::ImageOutput> out = OIIO::ImageOutput::create(path);
	if (!out) {
		return bc_errinfo_set(ei, BC_ENOTSUP, "%s: %s", path,
				      first_line(OIIO::geterror()).c_str());
	}
	int channels = static_cast<int>(img->channels);
	/* Formats without alpha (jpeg, pnm) take the colour channels only: the
	 * stride below skips the fourth sample. */
	if (channels == 4 && !out->supports("alpha")) {
		channels = 3;
	}
	OIIO::ImageSpec spec(static_cast<int>(img->width),
			     static_cast<int>(img->height), channels,
			     oiio_type(img->type));
	if (channels == 4) {
		spec.alpha_channel = 3;
	}
	/* Our RGBA is straight (unassociated) alpha: without this hint
	 * OpenImageIO would divide colour by alpha when writing PNG. */
	spec.attribute("oiio:UnassociatedAlpha", 1);
	std::string date;
	if (int rc = source_date(date, ei)) {
		return rc;
	}
	if (!date.empty()) {
		spec.attribute("DateTime", date);
	}
	if (!out->open(path, spec)) {
		return bc_errinfo_set(ei, BC_EIO, "%s: cannot open for writing: %s",
				      path, first_line(out->geterror()).c_str());
	}
	OIIO::stride_t xstride =
		static_cast<OIIO::stride_t>(ss * img->channels);
	bool ok = out->write_image(oiio_type(img->type), img->pixels, xstride);
	std::string why = ok ? std::string() : out->geterror();
	if (!out->close() && ok) {
		ok = false;
		why = out->geterror();
	}
	if (!ok) {
		return bc_errinfo_set(ei, BC_EIO, "%s: write failed: %s", path,
				      first_line(why).c_str());
	}
	return 0;
}

int read_image(const char *path, enum bc_image_type type,
	       struct bc_image *img, struct bc_errinfo *ei)
{
	/* Give samples back as stored: no premultiplication by alpha. */
	OIIO::ImageSpec config;
	config.attribute("oiio:UnassociatedAlpha", 1);
	std::unique_ptr<OIIO::ImageInput> in =
		OIIO::ImageInput::open(path, &config);
	if (!in) {
		return bc_errinfo_set(ei, BC_EIO, "%s: cannot read: %s", path,
				      first_line(OIIO::geterror()).c_str());
	}
	const OIIO::ImageSpec &spec = in->spec();
	if (spec.width <= 0 || spec.height <= 0 || spec.nchannels <= 0 ||
	    spec.depth > 1) {
		return bc_errinfo_set(ei, BC_EIO,
				      "%s: not a 2D image with channels", path);
	}
	uint64_t w = static_cast<uint64_t>(spec.width);
	uint64_t h = static_cast<uint64_t>(spec.height);
	uint64_t c = static_cast<uint64_t>(spec.nchannels);
	if (w > BC_IMAGE_MAX_DIM || h > BC_IMAGE_MAX_DIM ||
	    c > BC_IMAGE_MAX_CHANNELS || w * h * c > BC_IMAGE_MAX_SAMPLES) {
		return bc_errinfo_set(ei, BC_ELIMIT,
				      "%s: %llux%llu with %llu channels is over "
				      "the reader's limits",
				      path, static_cast<unsigned long long>(w),
				      static_cast<unsigned long long>(h),
				      static_cast<unsigned long long>(c));
	}
	void *pixels = host->calloc(static_cast<size_t>(w * h * c),
				 sample_size(type));
	if (!pixels) {
		return bc_errinfo_set(ei, BC_ENOMEM, "%s: out of memory", path);
	}
	if (!in->read_image(0, 0, 0, spec.nchannels, oiio_type(type),
			    pixels)) {
		host->free(pixels);
		return bc_errinfo_set(ei, BC_EIO, "%s: read failed: %s", path,
				      first_line(in->geterror()).c_str());
	}
	in->close();
	img->width = static_cast<uint32_t>(w);
	img->height = static_cast<uint32_t>(h);
	img->channels = static_cast<uint32_t>(c);
	img->type = type;
	img->pixels = pixels;
	return 0;
}


/* Whether OpenImageIO has a writer for the extension of path (image.c
 * answers for float and uint32 samples itself). */
bool module_ext_supports_u8(const char *path)
{
	try {
		bool ok = !extension(path).empty() &&
			  static_cast<bool>(OIIO::ImageOutput::create(path));
		/* A failed lookup leaves a message in OpenImageIO's global
		 * error; clear it so it does not leak into a later, unrelated
		 * reason. */
		(void)OIIO::geterror();
		return ok;
	} catch (const std::exception &) {
		return false;
	}
}

int module_write(const char *path, const struct bc_image *img,
		 struct bc_errinfo *ei)
{
	if (!path || !img || !img->pixels || img->width == 0 ||
	    img->height == 0 || img->width > BC_IMAGE_MAX_DIM ||
	    img->height > BC_IMAGE_MAX_DIM || img->channels == 0 ||
	    img->channels > 4 || sample_size(img->type) == 0) {
		return bc_errinfo_set(ei, BC_EINVAL,
				      "image write: bad image or path");
	}
	try {
		return write_image(path, img, ei);
	} catch (const std::exception &e) {
		return bc_errinfo_set(ei, BC_EIO, "%s: %s", path, e.what());
	}
}

int module_read(const char *path, enum bc_image_type type,
		struct bc_image *out, struct bc_errinfo *ei)
{
	if (!out) {
		return bc_errinfo_set(ei, BC_EINVAL, "image read: no output");
	}
	std::memset(out, 0, sizeof(*out));
	if (!path || sample_size(type) == 0) {
		return bc_errinfo_set(ei, BC_EINVAL,
				      "image read: bad path or sample type");
	}
	try {
		return read_image(path, type, out, ei);
	} catch (const std::exception &e) {
		return bc_errinfo_set(ei, BC_EIO, "%s: %s", path, e.what());
	}
}

const struct bc_image_ops ops = {
	BC_IMAGE_MODULE_ABI,
	module_ext_supports_u8,
	module_write,
	module_read,
};

} // namespace

extern "C" __attribute__((visibility("default"))) const struct bc_image_ops *
bc_image_module_open(const struct bc_image_host *h)
{
	if (!h || !h->calloc || !h->free || !h->ext_supports) {
		return nullptr;
	}
	host = h;
	return &ops;
}
