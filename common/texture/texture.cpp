#include "common/texture/texture.h"

#include "common/image/image.h"
#include "common/image/stderr_capture.h"
#include "common/system/budgets.h"
#include "common/system/error.h"
#include "common/system/temporary_directory.h"

#include <OpenImageIO/imagebuf.h>
#include <OpenImageIO/imagebufalgo.h>
#include <OpenImageIO/imageio.h>
#include <OpenImageIO/texture.h>
#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <ostream>
#include <string>
#include <system_error>
#include <utility>
#include <vector>

namespace mrt {

namespace {

namespace fs = std::filesystem;

/// Longest derivative passed to OpenImageIO, in texture widths. A footprint as wide as the
/// texture already averages all of it; longer ones only cost time (FOOTPRINT-NOTES: clamping
/// huge derivatives gave the same image in a third of the time).
constexpr float kMaxDerivativeLength = 1.0f;

/// Scale of the derivatives handed to OpenImageIO's anisotropic filter. It reads them as the
/// diameters of an ellipse and spreads its probes over 2·(major − minor) along the major axis,
/// each a bilinear lookup at the level where the minor axis is one texel, so its response is
/// wider than the box over the pixel's parallelogram. Measured: the RMS difference between its
/// response and the box's (sinc) for sinusoids of period 16–128 texels along either axis of
/// 2×2 … 32×8-texel footprints is 0.146 unscaled, 0.057 at 0.65 (the optimum), 0.070 at 0.75;
/// the RMSE of traced checker floors against 256-spp point-sampled references is lowest at
/// 0.75–0.8 (square pixels −15 %, pixels 3:1 −54 % against unscaled; see
/// tests/trace/raytrace/texture_filtering_test.cpp). 0.75 serves both.
constexpr float kAnisotropicFootprintScale = 0.75f;

/// OpenImageIO can queue several messages separated by newlines; ours are one line each.
std::string one_line(std::string message) {
    while (!message.empty() && std::isspace(static_cast<unsigned char>(message.back())) != 0) {
        message.pop_back();
    }
    std::replace(message.begin(), message.end(), '\n', ' ');
    return message.empty() ? "unknown OpenImageIO error" : message;
}

/// The first of OpenImageIO's queued messages (a failed write queues one per tile).
std::string first_line(const std::string& message) {
    return one_line(message.substr(0, message.find('\n')));
}

/// `d` shortened to at most kMaxDerivativeLength. The length is taken in double: in float,
/// d·d overflows from |d| ~ 1e19 and even hypot overflows near FLT_MAX, and an infinite length
/// would turn the clamp into a zero footprint.
Vec2f clamp_length(const Vec2f& d) {
    const double length = std::hypot(static_cast<double>(d.x()), static_cast<double>(d.y()));
    if (length <= kMaxDerivativeLength) {
        return d;
    }
    const double scale = kMaxDerivativeLength / length;
    return {static_cast<float>(d.x() * scale), static_cast<float>(d.y() * scale)};
}

/// The footprint as OpenImageIO wants it: (s, t) derivatives with t = 1 − v pointing down the
/// image, so the v components change sign. A non-finite derivative makes the whole footprint
/// unknown, which becomes a point sample (zero); long ones are clamped.
struct StFootprint {
    Vec2f dst_dx{0.0f, 0.0f};
    Vec2f dst_dy{0.0f, 0.0f};
};

StFootprint st_footprint(const UvFootprint& footprint) {
    if (!all_finite(footprint.duv_dx) || !all_finite(footprint.duv_dy)) {
        return {};
    }
    const Vec2f dx(footprint.duv_dx.x(), -footprint.duv_dx.y());
    const Vec2f dy(footprint.duv_dy.x(), -footprint.duv_dy.y());
    return {clamp_length(dx), clamp_length(dy)};
}

/// Number of colour channels looked up: 1 for grey (+ alpha), 3 for RGB (+ anything).
int colour_channels(int file_channels) {
    return file_channels >= 3 ? 3 : 1;
}

/// The channel an opacity texture reads: alpha where the file has it, else the first.
int opacity_channel(const OIIO::ImageSpec& spec) {
    if (spec.alpha_channel >= 0 && spec.alpha_channel < spec.nchannels) {
        return spec.alpha_channel;
    }
    if (spec.nchannels == 2) {
        return 1;
    }
    return spec.nchannels >= 4 ? 3 : 0;
}

/// Pixel type of the mip-map (a TIFF file, which stores half and float): 8-bit and half
/// values become half floats, finer than 8 bits at every brightness, which linearised 8-bit
/// values need in the dark; everything else becomes float.
OIIO::TypeDesc mipmap_format(OIIO::TypeDesc source) {
    const auto base = static_cast<OIIO::TypeDesc::BASETYPE>(source.basetype);
    const bool half_suffices = base == OIIO::TypeDesc::UINT8 || base == OIIO::TypeDesc::INT8 ||
                               base == OIIO::TypeDesc::HALF;
    return half_suffices ? OIIO::TypeDesc::HALF : OIIO::TypeDesc::FLOAT;
}

/// The file the TextureSystem reads for `texture`: the texture itself when it is already a tiled
/// mip-map needing no linearisation, otherwise a linear, tiled, box-filtered mip-map written as
/// `output` (see texture.h for why).
fs::path prepare_mipmap(const Texture& texture, const fs::path& output, const Budgets& budgets) {
    const fs::path& file = texture.path;
    // Straight alpha, as read_image: dropping alpha must leave the colours intact.
    OIIO::ImageSpec open_config;
    open_config.attribute("oiio:UnassociatedAlpha", 1);
    std::unique_ptr<OIIO::ImageInput> in = OIIO::ImageInput::open(file.string(), &open_config);
    if (!in) {
        throw Error(file, "", "cannot read texture: " + one_line(OIIO::geterror()));
    }
    const OIIO::ImageSpec spec = in->spec();
    if (spec.deep || spec.nchannels < 1 || spec.width < 1 || spec.height < 1 || spec.depth > 1) {
        throw Error(
            file, "",
            fmt::format("cannot read texture: unsupported layout ({}×{}, {} channels{})",
                        spec.width, spec.height, spec.nchannels, spec.deep ? ", deep" : ""));
    }
    // From the header, before any pixel is read or allocated: a few bytes of PNG header can
    // ask for gigabytes.
    check_budget(budgets, "pixels",
                 saturating_mul(static_cast<std::uint64_t>(spec.width),
                                static_cast<std::uint64_t>(spec.height)),
                 fmt::format("pixels (a {}×{} texture)", spec.width, spec.height), file, "");
    const bool opacity = texture.channel == TextureChannel::Opacity;
    const bool mipmapped = spec.tile_width > 0 && in->seek_subimage(0, 1);
    if (mipmapped && !texture.srgb && (!opacity || spec.nchannels == 1)) {
        return file;
    }

    const int first = opacity ? opacity_channel(spec) : 0;
    const int channels = opacity ? 1 : colour_channels(spec.nchannels);
    const std::size_t count = static_cast<std::size_t>(spec.width) *
                              static_cast<std::size_t>(spec.height) *
                              static_cast<std::size_t>(channels);
    std::vector<float> pixels(count);
    if (!in->read_image(0, 0, first, first + channels, OIIO::TypeDesc::FLOAT, pixels.data())) {
        throw Error(file, "", "cannot read texture: " + one_line(in->geterror()));
    }
    in->close();
    // Linearise before any filtering: the mip levels must average light, not encoded values.
    // Non-finite texels would spread into every level above them; they become black.
    for (float& v : pixels) {
        v = std::isfinite(v) ? (texture.srgb ? srgb_to_linear(v) : v) : 0.0f;
    }

    const OIIO::ImageSpec linear_spec(spec.width, spec.height, channels, OIIO::TypeDesc::FLOAT);
    const OIIO::ImageBuf linear(linear_spec, pixels.data());
    OIIO::ImageSpec config;
    config.format = mipmap_format(spec.format);
    config.tile_width = 64;
    config.tile_height = 64;
    config.tile_depth = 1;
    config.attribute("wrapmodes", "periodic,periodic");
    // Each level the 2×2 (or, for odd sizes, weighted) box average of the one below, as in
    // Williams's mip-map; the default bilinear resampling would point-sample odd sizes.
    config.attribute("maketx:filtername", "box");
    // The hash only serves OpenImageIO's de-duplication of identical files; skip its cost.
    config.attribute("maketx:hash", 0);
    // The image is in memory, so a failure here is the writing's: a full disk, a quota, a file
    // size limit. That is what the message says, about the directory, not the texture.
    errno = 0;
    if (!OIIO::ImageBufAlgo::make_texture(OIIO::ImageBufAlgo::MakeTxTexture, linear,
                                          output.string(), config)) {
        const int error = errno;
        std::string reason = first_line(OIIO::geterror());
        if (error == ENOSPC || error == EFBIG || error == EDQUOT || error == EIO ||
            error == EROFS || error == EACCES || error == EPERM) {
            reason = std::generic_category().message(error);
        }
        throw Error(
            output.parent_path(), "",
            fmt::format("cannot write the mip-map of texture '{}': {}", file.string(), reason));
    }
    return output;
}

/// Source of unique sampler ids for the per-thread cache below (never reused, unlike addresses).
std::atomic<std::uint64_t> g_next_sampler_id{1};

/// The calling thread's OpenImageIO state for the sampler it used last. OpenImageIO would find
/// it itself from a null pointer, through a per-thread map lookup on every call.
struct ThreadInfoCache {
    std::uint64_t sampler = 0;
    OIIO::TextureSystem::Perthread* info = nullptr;
};
thread_local ThreadInfoCache t_thread_info;

}  // namespace

TextureFilter parse_texture_filter(const std::string& text) {
    if (const std::optional<TextureFilter> filter = kTextureFilterNames.find(text)) {
        return *filter;
    }
    throw Error("texture filter: found \"" + text + "\", expected " +
                kTextureFilterNames.choices());
}

std::string to_string(TextureFilter filter) {
    return std::string(kTextureFilterNames.name(filter));
}

std::ostream& operator<<(std::ostream& os, TextureFilter filter) {
    return os << to_string(filter);
}

std::ostream& operator<<(std::ostream& os, const UvFootprint& footprint) {
    return os << "UvFootprint{duv_dx (" << footprint.duv_dx.x() << ", " << footprint.duv_dx.y()
              << "), duv_dy (" << footprint.duv_dy.x() << ", " << footprint.duv_dy.y() << ")}";
}

struct TextureSampler::Impl {
    std::uint64_t id = g_next_sampler_id.fetch_add(1);
    /// Declared before the system, so the files are removed after the system has closed them.
    std::unique_ptr<TemporaryDirectory> mipmaps;
    std::shared_ptr<OIIO::TextureSystem> system;
    std::vector<OIIO::TextureSystem::TextureHandle*> handles;
    std::vector<int> channels;
    /// Options of each filter, indexed by TextureFilter; copied per lookup because
    /// TextureSystem::texture takes them by non-const reference.
    std::array<OIIO::TextureOpt, kTextureFilterNames.size()> options;

    Impl() {
        for (OIIO::TextureOpt& o : options) {
            o.swrap = OIIO::TextureOpt::WrapPeriodic;
            o.twrap = OIIO::TextureOpt::WrapPeriodic;
            o.interpmode = OIIO::TextureOpt::InterpBilinear;
        }
        options[static_cast<std::size_t>(TextureFilter::None)].mipmode =
            OIIO::TextureOpt::MipModeNoMIP;
        options[static_cast<std::size_t>(TextureFilter::Distance)].mipmode =
            OIIO::TextureOpt::MipModeTrilinear;
        options[static_cast<std::size_t>(TextureFilter::Trilinear)].mipmode =
            OIIO::TextureOpt::MipModeTrilinear;
        OIIO::TextureOpt& aniso = options[static_cast<std::size_t>(TextureFilter::Anisotropic)];
        aniso.mipmode = OIIO::TextureOpt::MipModeAniso;
        aniso.anisotropic = static_cast<int>(kMaxAnisotropy);
        aniso.conservative_filter = true;
    }

    OIIO::TextureSystem::Perthread* thread_info() const {
        if (t_thread_info.sampler != id) {
            t_thread_info = {id, system->get_perthread_info()};
        }
        return t_thread_info.info;
    }

    Rgb sample(int index, const Vec2f& uv, const UvFootprint& footprint,
               TextureFilter filter) const {
        const auto i = static_cast<std::size_t>(index);
        OIIO::TextureOpt opt = options[static_cast<std::size_t>(filter)];
        // Image rows run top to bottom while v runs bottom to top. A non-finite coordinate would
        // make every interpolation weight NaN; it reads the corner instead.
        const float s = std::isfinite(uv.x()) ? uv.x() : 0.0f;
        const float t = std::isfinite(uv.y()) ? 1.0f - uv.y() : 1.0f;
        StFootprint st;
        switch (filter) {
            case TextureFilter::None:
                break;
            case TextureFilter::Distance:
            case TextureFilter::Trilinear: {
                // Eq. 26: one square filter as wide as the longer derivative. OpenImageIO's
                // trilinear mode takes max(|ds|, |dt|) over both derivatives, which would
                // underestimate a diagonal footprint by up to √2, so it gets the square itself.
                const StFootprint d = st_footprint(footprint);
                const float width = std::max(d.dst_dx.norm(), d.dst_dy.norm());
                st = {Vec2f(width, 0.0f), Vec2f(0.0f, width)};
                break;
            }
            case TextureFilter::Anisotropic: {
                const StFootprint d = st_footprint(footprint);
                st = {kAnisotropicFootprintScale * d.dst_dx, kAnisotropicFootprintScale * d.dst_dy};
                break;
            }
        }
        float result[3] = {0.0f, 0.0f, 0.0f};
        const int nchannels = channels[i];
        system->texture(handles[i], thread_info(), opt, s, t, st.dst_dx.x(), st.dst_dx.y(),
                        st.dst_dy.x(), st.dst_dy.y(), nchannels, result);
        if (nchannels == 1) {
            result[1] = result[2] = result[0];
        }
        return {result[0], result[1], result[2]};
    }
};

TextureSampler::TextureSampler(const Scene& scene, TextureFilter filter, const Budgets& budgets)
    : m_impl(std::make_unique<Impl>()), m_filter(filter) {
    if (scene.textures.empty()) {
        return;
    }
    m_impl->mipmaps = std::make_unique<TemporaryDirectory>("mrt-textures", "mip-mapped textures");
    m_impl->system = std::shared_ptr<OIIO::TextureSystem>(
        OIIO::TextureSystem::create(false),
        [](OIIO::TextureSystem* ts) { OIIO::TextureSystem::destroy(ts); });
    // Files used in place keep straight alpha as stored, like the converted ones.
    m_impl->system->attribute("unassociatedalpha", 1);
    for (std::size_t i = 0; i < scene.textures.size(); ++i) {
        const Texture& texture = scene.textures[i];
        // libpng prints its own line for a damaged file before OpenImageIO returns the same
        // failure: the one line of our error names it.
        StderrCapture library_messages;
        const fs::path file =
            prepare_mipmap(texture, m_impl->mipmaps->path() / fmt::format("{}.tif", i), budgets);
        const OIIO::ustring name(file.string());
        OIIO::TextureSystem::TextureHandle* handle = m_impl->system->get_texture_handle(name);
        const OIIO::ImageSpec* spec =
            handle != nullptr ? m_impl->system->imagespec(handle, nullptr, 0) : nullptr;
        if (spec == nullptr) {
            const std::string why = one_line(m_impl->system->geterror());
            throw Error(texture.path, "", "cannot read texture: " + why);
        }
        library_messages.pass_through();
        m_impl->handles.push_back(handle);
        m_impl->channels.push_back(
            texture.channel == TextureChannel::Opacity ? 1 : colour_channels(spec->nchannels));
    }
}

TextureSampler::~TextureSampler() = default;

Rgb TextureSampler::lookup(int index, const Vec2f& uv) const {
    return m_impl->sample(index, uv, UvFootprint{}, TextureFilter::None);
}

Rgb TextureSampler::lookup(int index, const Vec2f& uv, const UvFootprint& footprint) const {
    return m_impl->sample(index, uv, footprint, m_filter);
}

}  // namespace mrt
