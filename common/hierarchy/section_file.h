#pragma once
// The binary container of the hierarchy file (.mrh): a versioned, little-endian file of named
// sections, each a flat array of fixed-size records that the tracer memory-maps and uses in
// place, without parsing. The container knows nothing about octrees or surfels; the hierarchy
// file (preprocess/, trace/) decides which sections exist and what their records are.
//
// Layout (all integers little-endian; big-endian hosts are not supported):
//
//   offset  size  field
//   ------  ----  ---------------------------------------------------------------------------
//        0     8  magic "\x89MRH\r\n\x1a\n" (as PNG's: the high byte catches 7-bit transfers,
//                 CR LF and LF catch line-ending conversion, ^Z stops DOS `type`)
//        8     4  u32 format version (the hierarchy file's, not the container's)
//       12     4  u32 section count N
//       16     8  u64 total file size in bytes
//       24     8  u64 header checksum: section_checksum(table, section_checksum(bytes [0, 24)))
//       32  32*N  section table, one 32-byte entry per section, in file order:
//                   +0  u32 tag (four characters, first character in the lowest byte, so the
//                       file spells "NODE"; see section_tag)
//                   +4  u32 element size in bytes (0: untyped bytes); the size is a multiple
//                   +8  u64 offset of the section's first byte from the start of the file
//                  +16  u64 size of the section in bytes
//                  +24  u64 section_checksum of the section's bytes
//   then the sections, in table order, each at the first multiple of 64 at or after the end of
//   what precedes it; the gaps are zero bytes. The file ends where its last section ends (at
//   the end of the table when there are no sections).
//
// The layout is canonical: a given list of sections has exactly one valid file, and every byte
// of it is covered by a check (header and table by the header checksum, padding by being zero,
// section bytes by their checksums, the end by the recorded size). The reader therefore refuses
// any damaged file instead of returning wrong data, up to checksum collisions (2^-64).
//
// Writing goes to a temporary file beside the target, renamed into place when complete
// (common/system/atomic_file.h). Reading memory-maps the file read-only and validates all of the
// above before handing out a single byte; the mapping must not be truncated by another process
// while open (POSIX would deliver SIGBUS), which is the usual contract of memory-mapped files.

#include <bit>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <span>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

namespace mrt {

static_assert(std::endian::native == std::endian::little,
              "the hierarchy file is little-endian and read in place; big-endian hosts are not "
              "supported");

/// Every section starts at a multiple of this many bytes from the start of the file (and so of
/// the page-aligned mapping): records up to this alignment can be used in place, and a section
/// never shares a cache line with another.
inline constexpr std::size_t kSectionAlignment = 64;

/// A section's tag from its four-character name: section_tag("NODE"). The first character is
/// the lowest byte, so the tag reads "NODE" in the file.
constexpr std::uint32_t section_tag(const char (&name)[5]) {
    return static_cast<std::uint32_t>(static_cast<unsigned char>(name[0])) |
           static_cast<std::uint32_t>(static_cast<unsigned char>(name[1])) << 8 |
           static_cast<std::uint32_t>(static_cast<unsigned char>(name[2])) << 16 |
           static_cast<std::uint32_t>(static_cast<unsigned char>(name[3])) << 24;
}

/// A tag's four characters for messages ("NODE"); bytes outside printable ASCII, and the
/// backslash, are escaped as "\xHH".
std::string tag_name(std::uint32_t tag);

/// The container's 64-bit checksum of `bytes`, chained from `seed` (the checksum of what came
/// before, or 0). A corruption detector, not a cryptographic hash: four independent
/// multiply-rotate lanes over 8-byte little-endian words, so any single changed word changes its
/// lane (each step is a bijection of the lane), merged and avalanched at the end; the length
/// enters too, so appended or removed zero bytes are seen. Part of the file format: changing it
/// changes every file, so it needs a new format version.
std::uint64_t section_checksum(std::span<const std::byte> bytes, std::uint64_t seed = 0);

/// One entry of the section table, as the reader validated it.
struct SectionInfo {
    std::uint32_t tag = 0;           ///< Four-character tag (section_tag).
    std::uint32_t element_size = 0;  ///< Bytes per record; 0 for untyped bytes.
    std::uint64_t offset = 0;        ///< First byte, from the start of the file (multiple of 64).
    std::uint64_t size = 0;          ///< Length in bytes (a multiple of element_size).
    std::uint64_t checksum = 0;      ///< section_checksum of the bytes.
};

/// Collects sections in memory and writes them as one file. Sections keep the order they were
/// added in, so the same additions always give the same bytes.
class SectionFileWriter {
  public:
    /// `version` is the format version written into the header, which the reader must expect.
    explicit SectionFileWriter(std::uint32_t version) : m_version(version) {}

    /// Adds a section holding a copy of `bytes`. `element_size` is the record size (0 for
    /// untyped bytes), recorded so a reader with a different record layout is refused; the size
    /// must be a multiple of it. Throws mrt::Error for a tag already added or a size that is not
    /// a multiple of the element size.
    void add(std::uint32_t tag, std::span<const std::byte> bytes, std::uint32_t element_size = 0);

    /// As above, taking ownership of `bytes` instead of copying them.
    void add(std::uint32_t tag, std::vector<std::byte>&& bytes, std::uint32_t element_size = 0);

    /// Adds an array of records as a section whose element size is sizeof(T). The bytes are T's
    /// object representation: T must have no padding, or the file would hold indeterminate
    /// bytes (static_assert the record's size where it is defined).
    template <class T>
    void add_array(std::uint32_t tag, std::span<const T> values) {
        static_assert(std::is_trivially_copyable_v<T>, "sections hold trivially copyable records");
        static_assert(sizeof(T) <= 0xFFFFFFFFu, "record too large for the section table");
        add(tag, std::as_bytes(values), static_cast<std::uint32_t>(sizeof(T)));
    }

    /// Writes the file atomically (a temporary beside `file`, renamed into place). Throws
    /// mrt::Error naming the file; on failure no temporary is left and an existing `file` is
    /// unchanged.
    void write(const std::filesystem::path& file) const;

  private:
    struct Section {
        std::uint32_t tag;
        std::uint32_t element_size;
        std::vector<std::byte> bytes;
    };

    std::uint32_t m_version;
    std::vector<Section> m_sections;
};

/// A read-only memory mapping of a whole file, unmapped by the destructor. Move-only.
class MappedFile {
  public:
    MappedFile() = default;
    /// Maps `file`. Throws mrt::Error naming the file when it cannot be opened, is not a regular
    /// file or cannot be mapped. An empty file gives an empty mapping (mmap refuses length 0).
    explicit MappedFile(const std::filesystem::path& file);
    ~MappedFile();
    MappedFile(MappedFile&& other) noexcept;
    MappedFile& operator=(MappedFile&& other) noexcept;
    MappedFile(const MappedFile&) = delete;
    MappedFile& operator=(const MappedFile&) = delete;

    /// The file's bytes; the data is page-aligned.
    std::span<const std::byte> bytes() const { return {m_data, m_size}; }

  private:
    void unmap() noexcept;

    const std::byte* m_data = nullptr;  ///< Start of the mapping (not owned by anything else).
    std::size_t m_size = 0;             ///< Mapped length = file size in bytes.
};

/// A validated, memory-mapped section file. Section data stays valid while the object lives.
/// Whether the file at `path` begins like a section file (the first four bytes of the magic,
/// so that one whose magic was damaged in transfer still reaches SectionFile::open, which says
/// so); false when it cannot be read.
bool starts_like_section_file(const std::filesystem::path& path);

class SectionFile {
  public:
    /// Maps `file` and validates it completely (magic, version, header checksum, sizes,
    /// offsets, alignment, overlap, padding, every section's checksum) before returning.
    /// Throws mrt::Error with a one-line message "FILE: LOCATION: what is wrong, what was
    /// expected" for any file that is missing, foreign, of another version or damaged.
    static SectionFile open(const std::filesystem::path& file, std::uint32_t expected_version);

    /// The file it was opened from.
    const std::filesystem::path& path() const { return m_path; }
    /// The format version recorded in the header (= the expected one).
    std::uint32_t version() const { return m_version; }
    /// Total size of the file in bytes.
    std::uint64_t file_size() const { return m_file.bytes().size(); }
    /// The section table in file order (for mrt-info).
    const std::vector<SectionInfo>& sections() const { return m_sections; }

    /// Whether a section with this tag exists.
    bool has(std::uint32_t tag) const { return find(tag) != nullptr; }

    /// A section's bytes. Throws mrt::Error naming the file and the section when it is missing.
    std::span<const std::byte> bytes(std::uint32_t tag) const;

    /// A section as an array of T, used in place. Throws mrt::Error when the section is missing,
    /// was written with another element size, or its size is not a multiple of sizeof(T).
    template <class T>
    std::span<const T> array(std::uint32_t tag) const {
        static_assert(std::is_trivially_copyable_v<T>, "sections hold trivially copyable records");
        static_assert(alignof(T) <= kSectionAlignment, "sections are only 64-byte aligned");
        const std::span<const std::byte> b = bytes(tag);
        check_array(tag, b, sizeof(T), alignof(T));
        // The mapping holds T's object representation at a suitably aligned address; T is
        // trivially copyable, so its objects are implicitly created there (P0593).
        return {reinterpret_cast<const T*>(b.data()), b.size() / sizeof(T)};
    }

  private:
    SectionFile(std::filesystem::path path, MappedFile file, std::uint32_t version,
                std::vector<SectionInfo> sections)
        : m_path(std::move(path)),
          m_file(std::move(file)),
          m_version(version),
          m_sections(std::move(sections)) {}

    const SectionInfo* find(std::uint32_t tag) const;
    void check_array(std::uint32_t tag, std::span<const std::byte> bytes, std::size_t size,
                     std::size_t alignment) const;

    std::filesystem::path m_path;
    MappedFile m_file;
    std::uint32_t m_version;
    std::vector<SectionInfo> m_sections;
};

}  // namespace mrt
