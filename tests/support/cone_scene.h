#pragma once
// A scene for the cone tracer's end-to-end tests, prepared from JSON exactly as mrt-trace
// prepares a scene file, with the whitted and distributed images of the same scene to judge it by.

#include "common/image/image.h"
#include "common/scene_io/scene_loader.h"
#include "common/texture/texture.h"
#include "preprocess/hierarchy_pack.h"
#include "preprocess/scene_hierarchy.h"
#include "trace/bvh/scene_bvh.h"
#include "trace/cone/cone_tracer.h"
#include "trace/raytrace/distributed.h"
#include "trace/raytrace/whitted.h"

#include <nlohmann/json.hpp>

#include <filesystem>
#include <fstream>
#include <memory>
#include <string>

namespace mrt::testing {

/// A scene loaded from JSON and prepared for the cone tracer exactly as mrt-trace prepares a
/// scene file (trace/tools/mrt_trace_main.cpp): the hierarchy built with mrt-preprocess's defaults,
/// packed in memory, and the cone geometry over it.
class ConeScene {
  public:
    ConeScene(const std::filesystem::path& dir, const nlohmann::json& scene_json,
              const std::string& name)
        : m_scene(write_and_load(dir, scene_json, name)),
          m_textures(m_scene, TextureFilter::Anisotropic),
          m_data(build(m_scene)),
          m_geometry(m_data.view(), m_scene, m_textures) {}
    ConeScene(const ConeScene&) = delete;
    ConeScene& operator=(const ConeScene&) = delete;

    const Scene& scene() const { return m_scene; }
    const TextureSampler& textures() const { return m_textures; }
    /// The geometry reads the scene's background at render time: the same hierarchy renders
    /// against another background without being rebuilt.
    void set_background(const Rgb& background) { m_scene.background = background; }
    /// Likewise the camera.
    void set_camera(const Camera& camera) { m_scene.camera = camera; }

    const ConeGeometry& geometry() const { return m_geometry; }

    ConeRenderOutput render(int width, int height, const ConeOptions& cone = {},
                            int threads = 2) const {
        return render_cone(m_geometry, options(width, height, threads), cone);
    }

    /// The stochastic tracers' images of the same scene at `spp` samples per pixel (fixed,
    /// stratified), against which the cone's are judged: the distributed tracer's soft
    /// shadows, lens and glossy lobes, or whitted's point light and pinhole.
    Image distributed(int width, int height, int spp) const {
        return distributed(options(width, height), spp);
    }
    Image distributed(const RenderOptions& render_options, int spp) const {
        return render_distributed(m_scene, bvh(), m_textures, render_options,
                                  {.sampling = DistributedSampling::Fixed, .spp = spp})
            .image;
    }
    Image whitted(int width, int height, int spp) const {
        return render_whitted(m_scene, bvh(), m_textures, options(width, height), {.spp = spp})
            .image;
    }

    /// Render options for a width × height image, box filter, no progress bar.
    static RenderOptions options(int width, int height, int threads = 2) {
        RenderOptions options;
        options.width = width;
        options.height = height;
        options.threads = threads;
        options.quiet = true;
        options.filter = PixelFilter::box();
        return options;
    }

  private:
    const SceneBvh& bvh() const {
        if (!m_bvh) {
            m_bvh = std::make_unique<SceneBvh>(m_scene);
        }
        return *m_bvh;
    }
    static Scene write_and_load(const std::filesystem::path& dir, const nlohmann::json& scene_json,
                                const std::string& name) {
        std::ofstream(dir / name) << scene_json.dump(2);
        return load_scene(dir / name);
    }
    static HierarchyData build(const Scene& scene) {
        const std::unique_ptr<TextureSampler> prefilter =
            scene.textures.empty() ? nullptr
                                   : std::make_unique<TextureSampler>(scene, TextureFilter::None);
        const SceneHierarchy hierarchy =
            build_scene_hierarchy(scene, prefilter.get(), PointOctreeOptions{});
        return pack_hierarchy(hierarchy, scene.materials, "{}", "{}");
    }

    Scene m_scene;
    TextureSampler m_textures;
    HierarchyData m_data;
    ConeGeometry m_geometry;
    mutable std::unique_ptr<SceneBvh> m_bvh;  ///< Built for the first reference image.
};

}  // namespace mrt::testing
