#include "common/image/image.h"

#include "common/image/stderr_capture.h"
#include "common/system/error.h"

#include <OpenImageIO/imageio.h>
#include <OpenImageIO/strutil.h>
#include <fmt/format.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <system_error>

namespace mrt {

namespace {

enum class FileEncoding { LinearFloat, Srgb8 };

constexpr const char* kSupportedExtensions = ".exr, .hdr, .jpeg, .jpg, .png, .tif, .tiff";

std::string lower_extension(const std::filesystem::path& file) {
    std::string ext = file.extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(),
                   [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
    return ext;
}

FileEncoding encoding_for(const std::filesystem::path& file) {
    const std::string ext = lower_extension(file);
    if (ext == ".exr" || ext == ".hdr" || ext == ".tif" || ext == ".tiff") {
        return FileEncoding::LinearFloat;
    }
    if (ext == ".png" || ext == ".jpg" || ext == ".jpeg") {
        return FileEncoding::Srgb8;
    }
    throw Error(file, "",
                fmt::format("unsupported image extension '{}' (supported: {})",
                            file.extension().string(), kSupportedExtensions));
}

/// OpenImageIO can queue several messages separated by newlines; ours are one line each.
std::string one_line(std::string message) {
    while (!message.empty() && std::isspace(static_cast<unsigned char>(message.back())) != 0) {
        message.pop_back();
    }
    std::replace(message.begin(), message.end(), '\n', ' ');
    return message.empty() ? "unknown OpenImageIO error" : message;
}

float finite_or_zero(float v) {
    return std::isfinite(v) ? v : 0.0f;
}

std::vector<float> sanitized_float(const Image& image) {
    std::vector<float> out(image.data().size());
    std::transform(image.data().begin(), image.data().end(), out.begin(), finite_or_zero);
    return out;
}

std::vector<std::uint8_t> encoded_srgb8(const Image& image) {
    std::vector<std::uint8_t> out(image.data().size());
    std::transform(image.data().begin(), image.data().end(), out.begin(), [](float v) {
        // Clamping before encoding keeps out-of-gamut values at the nearest representable code.
        const float encoded = linear_to_srgb(std::clamp(finite_or_zero(v), 0.0f, 1.0f));
        return static_cast<std::uint8_t>(std::lround(encoded * 255.0f));
    });
    return out;
}

/// A name next to the target (so the final rename stays on one file system) that no other
/// writer, in this process or another, uses at the same time. The extension is kept because
/// some OpenImageIO plugins look at it.
std::filesystem::path temporary_name(const std::filesystem::path& file) {
    static std::atomic<unsigned> counter{0};
    const std::string name =
        fmt::format(".{}.{}-{}.tmp{}", file.filename().string(), static_cast<long>(::getpid()),
                    counter.fetch_add(1), file.extension().string());
    return file.parent_path() / name;
}

/// Removes the temporary file unless the write was committed, whatever path leaves the scope.
class TemporaryFile {
  public:
    explicit TemporaryFile(std::filesystem::path path) : m_path(std::move(path)) {}
    ~TemporaryFile() {
        if (!m_committed) {
            std::error_code ignored;
            std::filesystem::remove(m_path, ignored);
        }
    }
    TemporaryFile(const TemporaryFile&) = delete;
    TemporaryFile& operator=(const TemporaryFile&) = delete;

    const std::filesystem::path& path() const { return m_path; }
    void commit() { m_committed = true; }

  private:
    std::filesystem::path m_path;
    bool m_committed = false;
};

/// Why nothing can be written into the directory of `file`, if there is a reason.
std::optional<std::string> directory_problem(const std::filesystem::path& file) {
    const std::filesystem::path dir =
        file.parent_path().empty() ? std::filesystem::path(".") : file.parent_path();
    std::error_code ec;
    if (!std::filesystem::exists(dir, ec)) {
        return fmt::format("cannot write image: directory '{}' does not exist", dir.string());
    }
    if (!std::filesystem::is_directory(dir, ec)) {
        return fmt::format("cannot write image: '{}' is not a directory", dir.string());
    }
    if (::access(dir.c_str(), W_OK) != 0) {
        return fmt::format("cannot write image: directory '{}' is not writable", dir.string());
    }
    return std::nullopt;
}

std::string open_failure_reason(const std::filesystem::path& file, const std::string& oiio_error) {
    return directory_problem(file).value_or(fmt::format("cannot write image: {}", oiio_error));
}

bool is_srgb_encoded(const OIIO::ImageSpec& spec, const std::string& format_name) {
    const std::string colour_space = spec.get_string_attribute("oiio:ColorSpace");
    if (OIIO::Strutil::iequals(colour_space, "sRGB")) {
        return true;
    }
    // PNG and JPEG are sRGB unless the file says otherwise.
    return colour_space.empty() && (format_name == "png" || format_name == "jpeg");
}

}  // namespace

Image::Image(int width, int height, const Rgb& fill) {
    if (width < 0 || height < 0) {
        throw Error(fmt::format("image size must be non-negative, got {}×{}", width, height));
    }
    m_width = width;
    m_height = height;
    const std::size_t pixels = static_cast<std::size_t>(width) * static_cast<std::size_t>(height);
    m_pixels.resize(pixels * 3);
    for (std::size_t i = 0; i < pixels; ++i) {
        m_pixels[3 * i + 0] = fill[0];
        m_pixels[3 * i + 1] = fill[1];
        m_pixels[3 * i + 2] = fill[2];
    }
}

void check_image_output(const std::filesystem::path& file) {
    encoding_for(file);
    std::error_code ec;
    if (std::filesystem::is_directory(file, ec)) {
        throw Error(file, "", "cannot write image: is a directory");
    }
    if (const auto problem = directory_problem(file)) {
        throw Error(file, "", *problem);
    }
}

void write_image(const std::filesystem::path& file, const Image& image) {
    const FileEncoding encoding = encoding_for(file);
    if (image.empty()) {
        throw Error(
            file, "",
            fmt::format("cannot write an empty image ({}×{})", image.width(), image.height()));
    }

    // Declared before the output so the output is closed before the temporary is removed.
    TemporaryFile temporary(temporary_name(file));
    {
        // The plugin is chosen from the real name; the temporary only carries the bytes.
        std::unique_ptr<OIIO::ImageOutput> out = OIIO::ImageOutput::create(file.string());
        if (!out) {
            throw Error(file, "",
                        fmt::format("cannot write image: {}", one_line(OIIO::geterror())));
        }
        const OIIO::TypeDesc type =
            encoding == FileEncoding::Srgb8 ? OIIO::TypeDesc::UINT8 : OIIO::TypeDesc::FLOAT;
        OIIO::ImageSpec spec(image.width(), image.height(), 3, type);
        spec.attribute("oiio:ColorSpace", encoding == FileEncoding::Srgb8 ? "sRGB" : "Linear");
        // The same image must be the same bytes: the OpenEXR and TIFF writers stamp the time of
        // writing unless given a DateTime, and write none when it is empty.
        spec.attribute("DateTime", "");
        if (!out->open(temporary.path().string(), spec)) {
            throw Error(file, "", open_failure_reason(file, one_line(out->geterror())));
        }
        bool ok = false;
        if (encoding == FileEncoding::Srgb8) {
            const std::vector<std::uint8_t> pixels = encoded_srgb8(image);
            ok = out->write_image(OIIO::TypeDesc::UINT8, pixels.data());
        } else {
            const std::vector<float> pixels = sanitized_float(image);
            ok = out->write_image(OIIO::TypeDesc::FLOAT, pixels.data());
        }
        ok = out->close() && ok;
        if (!ok) {
            throw Error(file, "", fmt::format("cannot write image: {}", one_line(out->geterror())));
        }
    }

    std::error_code ec;
    std::filesystem::rename(temporary.path(), file, ec);
    if (ec) {
        throw Error(file, "",
                    fmt::format("cannot move the written image into place: {}", ec.message()));
    }
    temporary.commit();
}

Image read_image(const std::filesystem::path& file) {
    std::error_code ec;
    if (!std::filesystem::exists(file, ec)) {
        throw Error(file, "", "cannot read image: no such file");
    }
    if (std::filesystem::is_directory(file, ec)) {
        throw Error(file, "", "cannot read image: is a directory");
    }

    // libpng prints its own line for a damaged file before OpenImageIO returns the same
    // failure, which our one-line error reports.
    StderrCapture library_messages;
    // Straight (unassociated) alpha keeps colours intact when the alpha channel is dropped.
    OIIO::ImageSpec config;
    config.attribute("oiio:UnassociatedAlpha", 1);
    std::unique_ptr<OIIO::ImageInput> in = OIIO::ImageInput::open(file.string(), &config);
    if (!in) {
        throw Error(file, "", fmt::format("cannot read image: {}", one_line(OIIO::geterror())));
    }
    // A copy: some plugins reset their spec on close().
    const OIIO::ImageSpec spec = in->spec();
    const int channels = spec.nchannels;
    if (spec.deep || channels < 1 || spec.width < 0 || spec.height < 0) {
        throw Error(file, "",
                    fmt::format("cannot read image: unsupported layout ({}×{}, {} channels{})",
                                spec.width, spec.height, channels, spec.deep ? ", deep" : ""));
    }

    std::vector<float> raw(static_cast<std::size_t>(spec.width) *
                           static_cast<std::size_t>(spec.height) *
                           static_cast<std::size_t>(channels));
    if (!in->read_image(0, 0, 0, channels, OIIO::TypeDesc::FLOAT, raw.data())) {
        throw Error(file, "", fmt::format("cannot read image: {}", one_line(in->geterror())));
    }

    const bool integer_8_or_16 = !spec.format.is_floating_point() && spec.format.size() <= 2;
    const bool linearise = integer_8_or_16 && is_srgb_encoded(spec, in->format_name());
    in->close();
    library_messages.pass_through();

    Image image(spec.width, spec.height);
    std::vector<float>& pixels = image.data();
    const std::size_t count =
        static_cast<std::size_t>(spec.width) * static_cast<std::size_t>(spec.height);
    const std::size_t stride = static_cast<std::size_t>(channels);
    for (std::size_t i = 0; i < count; ++i) {
        const float* src = &raw[i * stride];
        for (std::size_t c = 0; c < 3; ++c) {
            // One or two channels are grey (plus alpha); more are RGB with extras ignored.
            const float v = channels >= 3 ? src[c] : src[0];
            pixels[3 * i + c] = linearise ? srgb_to_linear(v) : v;
        }
    }
    return image;
}

float linear_to_srgb(float linear) {
    const double l = linear;
    if (l <= 0.0031308) {
        return static_cast<float>(12.92 * l);
    }
    return static_cast<float>(1.055 * std::pow(l, 1.0 / 2.4) - 0.055);
}

float srgb_to_linear(float encoded) {
    const double e = encoded;
    if (e <= 0.04045) {
        return static_cast<float>(e / 12.92);
    }
    return static_cast<float>(std::pow((e + 0.055) / 1.055, 2.4));
}

}  // namespace mrt
