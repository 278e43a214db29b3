#include "common/texture.h"

#include "common/error.h"
#include "common/image.h"

#include <OpenImageIO/texture.h>

#include <vector>

namespace mrt {

struct TextureSampler::Impl {
    std::shared_ptr<OIIO::TextureSystem> system;
    std::vector<OIIO::TextureSystem::TextureHandle*> handles;
    std::vector<bool> srgb;
    std::vector<int> channels;
};

TextureSampler::TextureSampler(const Scene& scene) : m_impl(std::make_unique<Impl>()) {
    if (scene.textures.empty()) {
        return;
    }
    m_impl->system = std::shared_ptr<OIIO::TextureSystem>(
        OIIO::TextureSystem::create(false),
        [](OIIO::TextureSystem* ts) { OIIO::TextureSystem::destroy(ts); });
    for (const Texture& texture : scene.textures) {
        const OIIO::ustring name(texture.path.string());
        OIIO::TextureSystem::TextureHandle* handle = m_impl->system->get_texture_handle(name);
        const OIIO::ImageSpec* spec =
            handle != nullptr ? m_impl->system->imagespec(handle, nullptr, 0) : nullptr;
        if (spec == nullptr) {
            std::string why = m_impl->system->geterror();
            throw Error(texture.path, "", "cannot read texture" + (why.empty() ? "" : ": " + why));
        }
        m_impl->handles.push_back(handle);
        m_impl->srgb.push_back(texture.srgb);
        m_impl->channels.push_back(spec->nchannels);
    }
}

TextureSampler::~TextureSampler() = default;

Rgb TextureSampler::lookup(int index, const Vec2f& uv) const {
    const auto i = static_cast<std::size_t>(index);
    OIIO::TextureOpt options;
    options.swrap = OIIO::TextureOpt::WrapPeriodic;
    options.twrap = OIIO::TextureOpt::WrapPeriodic;
    options.mipmode = OIIO::TextureOpt::MipModeNoMIP;
    options.interpmode = OIIO::TextureOpt::InterpBilinear;
    float result[3] = {0.0f, 0.0f, 0.0f};
    const int nchannels = std::min(3, m_impl->channels[i]);
    // Image rows run top to bottom while v runs bottom to top.
    m_impl->system->texture(m_impl->handles[i], nullptr, options, uv.x(), 1.0f - uv.y(), 0.0f, 0.0f,
                            0.0f, 0.0f, nchannels, result);
    if (nchannels == 1) {
        result[1] = result[2] = result[0];
    }
    Rgb c(result[0], result[1], result[2]);
    if (m_impl->srgb[i]) {
        c = Rgb(srgb_to_linear(c[0]), srgb_to_linear(c[1]), srgb_to_linear(c[2]));
    }
    return c;
}

}  // namespace mrt
