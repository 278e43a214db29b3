#pragma once
// Linear-RGB float images and their file I/O (OpenImageIO, included only in image.cpp).
// .exr is written as linear float; .png/.jpg as 8-bit sRGB; chosen by the output's extension.

#include "common/math/math.h"

#include <filesystem>
#include <vector>

namespace mrt {

class Image {
  public:
    Image() = default;
    Image(int width, int height, const Rgb& fill = Rgb::Zero());

    int width() const { return m_width; }
    int height() const { return m_height; }
    bool empty() const { return m_width == 0 || m_height == 0; }

    /// Pixel (x, y), y = 0 the top row.
    Rgb at(int x, int y) const {
        const float* p = &m_pixels[index(x, y)];
        return {p[0], p[1], p[2]};
    }
    void set(int x, int y, const Rgb& c) {
        float* p = &m_pixels[index(x, y)];
        p[0] = c[0];
        p[1] = c[1];
        p[2] = c[2];
    }
    /// Interleaved RGB floats, row-major from the top row.
    const std::vector<float>& data() const { return m_pixels; }
    std::vector<float>& data() { return m_pixels; }

  private:
    std::size_t index(int x, int y) const {
        return (static_cast<std::size_t>(y) * static_cast<std::size_t>(m_width) +
                static_cast<std::size_t>(x)) *
               3;
    }
    int m_width = 0;
    int m_height = 0;
    std::vector<float> m_pixels;
};

/// Writes an image, format from the extension (.exr linear half/float, .png/.jpg/.jpeg sRGB 8 bit,
/// .hdr/.tif linear). NaN and Inf are replaced by 0 before writing (never written). The file
/// is written to a temporary name and renamed, so a failure leaves no partial file.
/// Throws mrt::Error naming the file.
void write_image(const std::filesystem::path& file, const Image& image);

/// Checks, before any work is done, that write_image could write `file`: a supported extension
/// and an existing, writable directory. Throws the mrt::Error write_image would.
void check_image_output(const std::filesystem::path& file);

/// Reads any image OpenImageIO can read into linear RGB (sRGB 8-bit files are linearised;
/// grey images are expanded; alpha is dropped). Throws mrt::Error naming the file.
Image read_image(const std::filesystem::path& file);

/// sRGB transfer curve (IEC 61966-2-1) and its inverse, per component.
float linear_to_srgb(float linear);
float srgb_to_linear(float encoded);

}  // namespace mrt
