// Cut-outs in the ray tracers' BVH (trace/bvh/cutouts.h): a leaf card's rays pass through its
// holes exactly where its alpha mask says, to whatever lies behind, for nearest hits and shadow
// queries alike, through instance transforms; and nothing changes without the cut-outs.

#include "trace/bvh/cutouts.h"
#include "common/scene_io/scene_loader.h"
#include "common/texture/texture.h"
#include "tests/support/leaf_texture.h"
#include "tests/support/test_support.h"
#include "trace/bvh/scene_bvh.h"

#include <gtest/gtest.h>

#include <string>

namespace mrt {
namespace {

constexpr int kTexels = 32;

/// A unit leaf card (the quad in the xz plane, uv (x + ½, ½ − z)), its opacity the leaf's alpha,
/// at height `height`, with a plain card below it at y = −1; the card is instanced through a
/// group turned and scaled by `transform` (JSON), or not at all.
std::string card_scene(const std::string& transform) {
    return R"({
      "camera": {"eye": [0, 5, 0.01], "look_at": [0, 0, 0], "fov": 30, "resolution": [8, 8]},
      "materials": {"leaf": {"texture": {"file": "leaf.png"},
                             "opacity_texture": {"file": "leaf.png"}},
                    "ground": {}},
      "groups": {"card": {"objects": [{"shape": "quad", "size": [1, 1], "material": "leaf"}]}},
      "objects": [{"instance": "card", "transform": )" +
           transform + R"(},
                  {"shape": "quad", "size": [4, 4], "material": "ground",
                   "transform": {"translate": [0, -1, 0]}}]
    })";
}

class Cutouts : public ::testing::Test {
  protected:
    void SetUp() override { testing::write_leaf_texture(m_scratch.path() / "leaf.png", kTexels); }

    Scene load(const std::string& transform) {
        testing::write_file(m_scratch.path() / "card.json", card_scene(transform));
        return load_scene(m_scratch.path() / "card.json");
    }

    testing::ScratchDirectory m_scratch{"mrt_cutouts_test"};
};

/// Every texel centre whose 3×3 neighbourhood is all in or all out of the leaf (the bilinear
/// opacity is then exactly 0 or 1 there), with whether it is in.
template <class F>
void for_each_clear_texel(F&& f) {
    for (int y = 1; y + 1 < kTexels; ++y) {
        for (int x = 1; x + 1 < kTexels; ++x) {
            const bool in = testing::leaf_texel(x, y, kTexels);
            bool clear = true;
            for (int dy = -1; dy <= 1; ++dy) {
                for (int dx = -1; dx <= 1; ++dx) {
                    clear = clear && testing::leaf_texel(x + dx, y + dy, kTexels) == in;
                }
            }
            if (clear) {
                f(x, y, in);
            }
        }
    }
}

TEST_F(Cutouts, RaysPassThroughTheHolesExactlyWhereTheMaskSaysToWhatLiesBehind) {
    const Scene scene = load(R"({"translate": [0, 0, 0]})");
    ASSERT_EQ(scene.textures.size(), 2u) << "the colour and the opacity of one file";
    const SceneBvh bvh(scene);
    const TextureSampler textures(scene);
    const SceneCutouts cutouts(scene, textures);
    ASSERT_FALSE(cutouts.empty());
    int inside = 0, outside = 0;
    for_each_clear_texel([&](int x, int y, bool in) {
        // Texel (x, y) is at uv ((x + ½)/n, 1 − (y + ½)/n): x = u − ½, z = ½ − v.
        const float px = (static_cast<float>(x) + 0.5f) / kTexels - 0.5f;
        const float pz = (static_cast<float>(y) + 0.5f) / kTexels - 0.5f;
        const Ray down{Vec3f(px, 1.0f, pz), Vec3f(0.0f, -1.0f, 0.0f), kInfinity};
        SceneHit hit;
        ASSERT_TRUE(bvh.intersect(down, hit, &cutouts)) << "the ground is behind every hole";
        EXPECT_NEAR(hit.t, in ? 1.0f : 2.0f, 1e-5f) << "texel " << x << "," << y;
        SceneHit opaque;
        ASSERT_TRUE(bvh.intersect(down, opaque));
        EXPECT_NEAR(opaque.t, 1.0f, 1e-5f) << "without cut-outs the card is whole";
        // A shadow ray to a light between the card and the ground is blocked only by the leaf.
        const Ray shadow{Vec3f(px, 1.0f, pz), Vec3f(0.0f, -1.0f, 0.0f), 1.5f};
        EXPECT_EQ(bvh.occluded(shadow, &cutouts), in) << "texel " << x << "," << y;
        EXPECT_TRUE(bvh.occluded(shadow));
        (in ? inside : outside) += 1;
    });
    EXPECT_GT(inside, 200);
    EXPECT_GT(outside, 200);
}

TEST_F(Cutouts, TheHolesFollowTheCardThroughItsInstanceTransform) {
    // Turned a quarter about y and scaled by 2: texel (x, y) now lies at (2z, 2·(−x)).
    const Scene scene = load(R"({"rotate": {"axis": [0, 1, 0], "degrees": 90}, "scale": 2})");
    const SceneBvh bvh(scene);
    const TextureSampler textures(scene);
    const SceneCutouts cutouts(scene, textures);
    for_each_clear_texel([&](int x, int y, bool in) {
        const float px = (static_cast<float>(x) + 0.5f) / kTexels - 0.5f;
        const float pz = (static_cast<float>(y) + 0.5f) / kTexels - 0.5f;
        // Rotation by +90° about y maps (x, z) to (z, −x).
        const Vec3f origin(2.0f * pz, 1.0f, -2.0f * px);
        SceneHit hit;
        ASSERT_TRUE(bvh.intersect(Ray{origin, Vec3f(0.0f, -1.0f, 0.0f), kInfinity}, hit, &cutouts));
        EXPECT_NEAR(hit.t, in ? 1.0f : 2.0f, 1e-5f) << "texel " << x << "," << y;
    });
}

TEST_F(Cutouts, AMeshWithoutTextureCoordinatesOrCutOutMaterialHasNone) {
    // The leaf material on a mesh without texture coordinates, and a card without it: neither
    // has holes, and a ray through either's would-be hole hits it.
    testing::write_file(m_scratch.path() / "bare.obj", "v -1 0 -1\nv -1 0 1\nv 1 0 1\nf 1 2 3\n");
    testing::write_file(m_scratch.path() / "plain.json", R"({
      "camera": {"eye": [0, 5, 0.01], "look_at": [0, 0, 0], "fov": 30, "resolution": [8, 8]},
      "materials": {"leaf": {"opacity_texture": {"file": "leaf.png"}}, "plain": {}},
      "objects": [{"shape": "mesh", "file": "bare.obj", "material": "leaf"},
                  {"shape": "quad", "size": [1, 1], "material": "plain",
                   "transform": {"translate": [0, -1, 0]}}]
    })");
    const Scene scene = load_scene(m_scratch.path() / "plain.json");
    ASSERT_TRUE(scene.materials[scene.meshes[0].materials[0]].cut_out());
    ASSERT_FALSE(scene.meshes[0].has_uvs());
    const TextureSampler textures(scene);
    const SceneCutouts cutouts(scene, textures);
    EXPECT_TRUE(cutouts.empty());
    // (-0.45, -0.45) lies in the leaf texture's transparent corner for any uv it could have.
    const SceneBvh bvh(scene);
    SceneHit hit;
    ASSERT_TRUE(bvh.intersect(Ray{Vec3f(-0.45f, 1.0f, 0.45f), Vec3f(0.0f, -1.0f, 0.0f), kInfinity},
                              hit, &cutouts));
    EXPECT_NEAR(hit.t, 1.0f, 1e-5f) << "the bare triangle, not the card below it";
}

}  // namespace
}  // namespace mrt
