#pragma once
// The reference image of a comparison and its record, DIR/reference.json:
//
//   {"key": {"scene", "scene_hash", "width", "height", "filter", "spp", "seed"},
//    "spp", "seconds", "std_error"}
//
// A reference costs far more than the runs it judges, so mrt-compare keeps it: a later
// comparison whose key is identical reuses DIR/reference.exr instead of rendering it again.
// The key names everything the reference image depends on that mrt-compare controls; it does
// not cover files the scene refers to (meshes, textures) or the mrt-trace build.

#include "trace/results/results.h"

#include <cstdint>
#include <filesystem>
#include <iosfwd>
#include <optional>
#include <string>

namespace mrt {

/// What a reference image depends on: references with equal keys are interchangeable.
struct ReferenceKey {
    std::string scene;           ///< Canonical path of the scene file.
    std::string scene_hash;      ///< Hash of the scene file's bytes (scene_file_hash).
    std::optional<int> width;    ///< Requested width in pixels; empty: the scene camera's.
    std::optional<int> height;   ///< Requested height in pixels; empty: the scene camera's.
    std::string filter;          ///< Pixel filter in canonical form ("box", "gaussian:0.5").
    std::string texture_filter;  ///< As --texture-filter spells it.
    int spp = 0;                 ///< Samples per pixel of the reference render.
    std::uint64_t seed = 0;      ///< Seed of the sample patterns.

    bool operator==(const ReferenceKey&) const = default;
};

/// 64-bit FNV-1a of the file's bytes as 16 hex digits: a change detector, not a digest that
/// resists tampering. Throws mrt::Error naming the file when it cannot be read.
std::string scene_file_hash(const std::filesystem::path& scene);

/// The canonical text of a pixel filter spec ("gaussian" → "gaussian:0.5"). Throws mrt::Error
/// for a spec mrt::parse_pixel_filter refuses.
std::string canonical_filter(const std::string& filter);

/// The record's info when `record` exists, parses, and holds a key equal to `key`; empty
/// otherwise (missing, unreadable, other key: the reference must be rendered again).
std::optional<ReferenceInfo> cached_reference_info(const std::filesystem::path& record,
                                                   const ReferenceKey& key);

/// Writes the record of a rendered reference (atomically). Throws mrt::Error.
void write_reference_record(const std::filesystem::path& record, const ReferenceKey& key,
                            const ReferenceInfo& info);

/// The info of a record (top-level "spp", "seconds", "std_error"; a missing or null entry is
/// unknown). Throws mrt::Error naming the file when it exists but is not such a record.
ReferenceInfo read_reference_info(const std::filesystem::path& record);

std::ostream& operator<<(std::ostream& os, const ReferenceKey& k);

}  // namespace mrt
