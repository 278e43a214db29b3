#include "common/hierarchy/section_file.h"

#include "common/system/atomic_file.h"
#include "common/system/error.h"

#include <fcntl.h>
#include <fmt/format.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <cstring>
#include <fstream>
#include <limits>

namespace mrt {

namespace {

// The byte layout of section_file.h's table, in one place.
constexpr std::array<unsigned char, 8> kMagic = {0x89, 'M', 'R', 'H', '\r', '\n', 0x1a, '\n'};
constexpr std::size_t kVersionAt = 8;
constexpr std::size_t kCountAt = 12;
constexpr std::size_t kFileSizeAt = 16;
constexpr std::size_t kChecksumAt = 24;
constexpr std::size_t kHeaderSize = 32;
constexpr std::size_t kEntrySize = 32;
constexpr std::size_t kEntryTagAt = 0;
constexpr std::size_t kEntryElementSizeAt = 4;
constexpr std::size_t kEntryOffsetAt = 8;
constexpr std::size_t kEntrySizeAt = 16;
constexpr std::size_t kEntryChecksumAt = 24;

constexpr std::uint64_t kMax = std::numeric_limits<std::uint64_t>::max();

std::uint64_t load_u64(const std::byte* p) {
    std::uint64_t v;
    std::memcpy(&v, p, sizeof v);
    return v;
}

std::uint32_t load_u32(const std::byte* p) {
    std::uint32_t v;
    std::memcpy(&v, p, sizeof v);
    return v;
}

template <class T>
void store(std::vector<std::byte>& out, std::size_t at, T value) {
    std::memcpy(out.data() + at, &value, sizeof value);
}

/// `x` rounded up to the section alignment, or false when that does not fit in 64 bits.
bool checked_align(std::uint64_t x, std::uint64_t& out) {
    if (x > kMax - (kSectionAlignment - 1)) {
        return false;
    }
    out = (x + (kSectionAlignment - 1)) / kSectionAlignment * kSectionAlignment;
    return true;
}

// The checksum's constants: odd 64-bit multipliers with well-mixed bits (the golden ratio's,
// two of xxHash64's primes and MurmurHash3's finaliser's), so each multiplication is a bijection
// that spreads every input bit upwards, and the rotations bring the high bits back down.
constexpr std::uint64_t kK1 = 0x9E3779B97F4A7C15ull;
constexpr std::uint64_t kK2 = 0xC2B2AE3D27D4EB4Full;
constexpr std::uint64_t kK3 = 0xFF51AFD7ED558CCDull;
constexpr std::uint64_t kK4 = 0xC4CEB9FE1A85EC53ull;
constexpr std::uint64_t kK5 = 0x27D4EB2F165667C5ull;

/// One lane step: a bijection of `lane` for a fixed word and of the word for a fixed lane, so a
/// changed word always changes the lane, and later steps keep it changed.
inline std::uint64_t mix_word(std::uint64_t lane, std::uint64_t word) {
    return std::rotl(lane + word * kK2, 31) * kK1;
}

/// MurmurHash3's 64-bit finaliser: every input bit affects every output bit.
inline std::uint64_t avalanche(std::uint64_t h) {
    h ^= h >> 33;
    h *= kK3;
    h ^= h >> 33;
    h *= kK4;
    h ^= h >> 33;
    return h;
}

std::string section_location(std::uint32_t tag) {
    return fmt::format("section '{}'", tag_name(tag));
}

}  // namespace

std::string tag_name(std::uint32_t tag) {
    std::string name;
    for (int i = 0; i < 4; ++i) {
        const auto c = static_cast<unsigned char>(tag >> (8 * i));
        if (c >= 0x20 && c < 0x7f && c != '\\' && c != '\'') {
            name += static_cast<char>(c);
        } else {
            name += fmt::format("\\x{:02x}", c);
        }
    }
    return name;
}

// Four lanes over 32-byte stripes keep four independent multiply chains in flight (the
// structure of xxHash64, not its values); the tail words and bytes go through a single chain.
// About 22 GB/s on one core of an AMD EPYC at -O3, faster than memcpy of the same bytes, so
// validating a file costs little next to reading it from the disk.
std::uint64_t section_checksum(std::span<const std::byte> bytes, std::uint64_t seed) {
    const std::byte* p = bytes.data();
    std::size_t remaining = bytes.size();
    std::uint64_t h;
    if (remaining >= 32) {
        std::uint64_t v0 = seed + kK1 + kK2;
        std::uint64_t v1 = seed + kK2;
        std::uint64_t v2 = seed;
        std::uint64_t v3 = seed - kK1;
        for (; remaining >= 32; remaining -= 32, p += 32) {
            v0 = mix_word(v0, load_u64(p));
            v1 = mix_word(v1, load_u64(p + 8));
            v2 = mix_word(v2, load_u64(p + 16));
            v3 = mix_word(v3, load_u64(p + 24));
        }
        h = std::rotl(v0, 1) + std::rotl(v1, 7) + std::rotl(v2, 12) + std::rotl(v3, 18);
        for (const std::uint64_t v : {v0, v1, v2, v3}) {
            h = (h ^ mix_word(0, v)) * kK1 + kK4;
        }
    } else {
        h = seed + kK5;
    }
    h += static_cast<std::uint64_t>(bytes.size());
    for (; remaining >= 8; remaining -= 8, p += 8) {
        h ^= mix_word(0, load_u64(p));
        h = std::rotl(h, 27) * kK1 + kK4;
    }
    if (remaining > 0) {
        std::uint64_t last = 0;
        std::memcpy(&last, p, remaining);
        h ^= last * kK5;
        h = std::rotl(h, 23) * kK2 + kK3;
    }
    return avalanche(h);
}

// ------------------------------------------------------------------------------------ writer

void SectionFileWriter::add(std::uint32_t tag, std::span<const std::byte> bytes,
                            std::uint32_t element_size) {
    add(tag, std::vector<std::byte>(bytes.begin(), bytes.end()), element_size);
}

void SectionFileWriter::add(std::uint32_t tag, std::vector<std::byte>&& bytes,
                            std::uint32_t element_size) {
    for (const Section& s : m_sections) {
        if (s.tag == tag) {
            throw Error(fmt::format("section '{}' added twice to a hierarchy file", tag_name(tag)));
        }
    }
    if (element_size != 0 && bytes.size() % element_size != 0) {
        throw Error(fmt::format("section '{}': {} bytes are not a whole number of {}-byte records",
                                tag_name(tag), bytes.size(), element_size));
    }
    if (m_sections.size() == std::numeric_limits<std::uint32_t>::max()) {
        throw Error("a hierarchy file holds at most 2^32 - 1 sections");
    }
    m_sections.push_back({tag, element_size, std::move(bytes)});
}

void SectionFileWriter::write(const std::filesystem::path& file) const {
    static constexpr std::array<std::byte, kSectionAlignment> kZeros{};
    const std::size_t table_end = kHeaderSize + kEntrySize * m_sections.size();
    std::vector<std::byte> head(table_end);
    std::vector<std::span<const std::byte>> pieces;
    pieces.reserve(2 * m_sections.size() + 1);
    pieces.emplace_back(head);

    std::uint64_t cursor = table_end;
    for (std::size_t i = 0; i < m_sections.size(); ++i) {
        const Section& s = m_sections[i];
        std::uint64_t offset = 0;
        if (!checked_align(cursor, offset) || s.bytes.size() > kMax - offset) {
            throw Error(file, "", "the sections exceed a 64-bit file size");
        }
        const std::size_t entry = kHeaderSize + kEntrySize * i;
        store(head, entry + kEntryTagAt, s.tag);
        store(head, entry + kEntryElementSizeAt, s.element_size);
        store(head, entry + kEntryOffsetAt, offset);
        store(head, entry + kEntrySizeAt, static_cast<std::uint64_t>(s.bytes.size()));
        store(head, entry + kEntryChecksumAt, section_checksum(s.bytes));
        pieces.emplace_back(kZeros.data(), static_cast<std::size_t>(offset - cursor));
        pieces.emplace_back(s.bytes);
        cursor = offset + s.bytes.size();
    }

    std::memcpy(head.data(), kMagic.data(), kMagic.size());
    store(head, kVersionAt, m_version);
    store(head, kCountAt, static_cast<std::uint32_t>(m_sections.size()));
    store(head, kFileSizeAt, cursor);
    const std::span<const std::byte> all(head);
    store(head, kChecksumAt,
          section_checksum(all.subspan(kHeaderSize), section_checksum(all.first(kChecksumAt))));
    write_file_atomically(file, pieces, "hierarchy file");
}

// -------------------------------------------------------------------------------- mapping

MappedFile::MappedFile(const std::filesystem::path& file) {
    const int fd = ::open(file.c_str(), O_RDONLY | O_CLOEXEC);
    if (fd < 0) {
        throw Error(file, "", fmt::format("cannot be opened: {}", std::strerror(errno)));
    }
    struct Closer {
        int fd;
        ~Closer() { ::close(fd); }
    } closer{fd};
    struct stat status {};
    if (::fstat(fd, &status) != 0) {
        throw Error(file, "", fmt::format("cannot be examined: {}", std::strerror(errno)));
    }
    if (S_ISDIR(status.st_mode)) {
        throw Error(file, "", "is a directory, expected an mrtrace hierarchy file");
    }
    if (!S_ISREG(status.st_mode)) {
        throw Error(file, "", "is not a regular file, expected an mrtrace hierarchy file");
    }
    if (status.st_size == 0) {
        return;
    }
    const auto size = static_cast<std::size_t>(status.st_size);
    void* data = ::mmap(nullptr, size, PROT_READ, MAP_PRIVATE, fd, 0);
    if (data == MAP_FAILED) {
        throw Error(file, "", fmt::format("cannot be memory-mapped: {}", std::strerror(errno)));
    }
    m_data = static_cast<const std::byte*>(data);
    m_size = size;
}

MappedFile::~MappedFile() {
    unmap();
}

MappedFile::MappedFile(MappedFile&& other) noexcept
    : m_data(std::exchange(other.m_data, nullptr)), m_size(std::exchange(other.m_size, 0)) {}

MappedFile& MappedFile::operator=(MappedFile&& other) noexcept {
    if (this != &other) {
        unmap();
        m_data = std::exchange(other.m_data, nullptr);
        m_size = std::exchange(other.m_size, 0);
    }
    return *this;
}

void MappedFile::unmap() noexcept {
    if (m_data != nullptr) {
        // munmap takes a non-const pointer; the mapping was created by us, read-only.
        ::munmap(const_cast<std::byte*>(m_data), m_size);
        m_data = nullptr;
        m_size = 0;
    }
}

// ---------------------------------------------------------------------------------- reader

bool starts_like_section_file(const std::filesystem::path& path) {
    std::ifstream in(path, std::ios::binary);
    std::array<char, 4> start{};
    return in.read(start.data(), start.size()) &&
           std::memcmp(start.data(), kMagic.data(), start.size()) == 0;
}

namespace {

std::string hex_bytes(std::span<const std::byte> bytes) {
    std::string s;
    for (const std::byte b : bytes) {
        s += fmt::format("{}{:02x}", s.empty() ? "" : " ", static_cast<unsigned>(b));
    }
    return s;
}

/// Refuses a file that does not start with the magic number (or, when shorter, a prefix of it).
void check_magic(const std::filesystem::path& file, std::span<const std::byte> bytes) {
    const std::size_t n = std::min(bytes.size(), kMagic.size());
    const auto same = [&](std::size_t count) {
        return std::memcmp(bytes.data(), kMagic.data(), std::min(count, n)) == 0;
    };
    if (same(kMagic.size())) {
        return;
    }
    if (n > 4 && same(4)) {
        throw Error(file, "header",
                    fmt::format("the magic number is damaged: bytes 4 to 7 are {}, expected 0d 0a "
                                "1a 0a (was the file transferred in text mode?)",
                                hex_bytes(bytes.subspan(4, n - 4))));
    }
    throw Error(file, "",
                fmt::format("not an mrtrace hierarchy file: it starts with {}, expected the magic "
                            "number 89 4d 52 48 0d 0a 1a 0a (\"\\x89MRH\\r\\n\\x1a\\n\")",
                            hex_bytes(bytes.first(n))));
}

}  // namespace

SectionFile SectionFile::open(const std::filesystem::path& file, std::uint32_t expected_version) {
    MappedFile mapping(file);
    const std::span<const std::byte> bytes = mapping.bytes();
    const std::uint64_t n = bytes.size();
    const std::byte* base = bytes.data();
    if (n == 0) {
        throw Error(file, "", "is empty (0 bytes), expected an mrtrace hierarchy file");
    }
    check_magic(file, bytes);
    if (n < kHeaderSize) {
        throw Error(
            file, "header",
            fmt::format("truncated: the file has {} bytes, the header alone {}", n, kHeaderSize));
    }
    const std::uint32_t version = load_u32(base + kVersionAt);
    if (version != expected_version) {
        throw Error(file, "header",
                    fmt::format("format version {} found, version {} expected (rebuild the file "
                                "with this mrtrace's mrt-preprocess)",
                                version, expected_version));
    }
    const std::uint32_t count = load_u32(base + kCountAt);
    // At most 32 + 32 * (2^32 - 1) < 2^38: no overflow.
    const std::uint64_t table_end = kHeaderSize + std::uint64_t{kEntrySize} * count;
    if (table_end > n) {
        throw Error(file, "section table",
                    fmt::format("truncated: {} sections need a table ending at byte {}, the file "
                                "has {} bytes",
                                count, table_end, n));
    }
    const std::uint64_t stored_checksum = load_u64(base + kChecksumAt);
    const std::uint64_t header_checksum =
        section_checksum(bytes.subspan(kHeaderSize, table_end - kHeaderSize),
                         section_checksum(bytes.first(kChecksumAt)));
    if (stored_checksum != header_checksum) {
        throw Error(file, "header",
                    fmt::format("checksum {:#018x} recorded, {:#018x} computed over the header and "
                                "section table: the file is damaged",
                                stored_checksum, header_checksum));
    }
    const std::uint64_t recorded_size = load_u64(base + kFileSizeAt);
    if (recorded_size != n) {
        throw Error(file, "header",
                    fmt::format("{}: the file has {} bytes, its header records {}",
                                n < recorded_size ? "truncated" : "extended", n, recorded_size));
    }

    // Structure first (cheap), then the section checksums (a pass over the whole file).
    std::vector<SectionInfo> sections(count);
    std::uint64_t cursor = table_end;  // end of what precedes the next section
    for (std::uint32_t i = 0; i < count; ++i) {
        const std::byte* entry = base + kHeaderSize + std::size_t{kEntrySize} * i;
        SectionInfo& s = sections[i];
        s.tag = load_u32(entry + kEntryTagAt);
        s.element_size = load_u32(entry + kEntryElementSizeAt);
        s.offset = load_u64(entry + kEntryOffsetAt);
        s.size = load_u64(entry + kEntrySizeAt);
        s.checksum = load_u64(entry + kEntryChecksumAt);
        const std::string where = section_location(s.tag);
        for (std::uint32_t j = 0; j < i; ++j) {
            if (sections[j].tag == s.tag) {
                throw Error(file, where,
                            fmt::format("appears twice in the section table (entries {} and {}), "
                                        "expected once",
                                        j, i));
            }
        }
        if (s.offset % kSectionAlignment != 0) {
            throw Error(
                file, where,
                fmt::format("offset {} is not a multiple of {}", s.offset, kSectionAlignment));
        }
        if (s.offset < table_end) {
            throw Error(file, where,
                        fmt::format("offset {} overlaps the header and section table, which end "
                                    "at byte {}",
                                    s.offset, table_end));
        }
        if (s.size > kMax - s.offset) {
            throw Error(file, where,
                        fmt::format("offset {} + size {} overflows a 64-bit file position",
                                    s.offset, s.size));
        }
        const std::uint64_t end = s.offset + s.size;
        if (end > n) {
            throw Error(
                file, where,
                fmt::format("bytes {} to {} lie outside the {}-byte file", s.offset, end, n));
        }
        if (s.offset < cursor) {
            throw Error(file, where,
                        fmt::format("bytes {} to {} overlap section '{}', which ends at byte {}",
                                    s.offset, end, tag_name(sections[i - 1].tag), cursor));
        }
        std::uint64_t expected_offset = 0;
        checked_align(cursor, expected_offset);  // cursor <= n, far from overflowing
        if (s.offset != expected_offset) {
            throw Error(file, where,
                        fmt::format("offset {}, expected {} (sections follow each other in table "
                                    "order, each at the next multiple of {})",
                                    s.offset, expected_offset, kSectionAlignment));
        }
        if (s.element_size != 0 && s.size % s.element_size != 0) {
            throw Error(file, where,
                        fmt::format("size {} is not a multiple of its {}-byte element size", s.size,
                                    s.element_size));
        }
        for (std::uint64_t at = cursor; at < s.offset; ++at) {
            if (base[at] != std::byte{0}) {
                throw Error(file, where,
                            fmt::format("padding byte {} before it is {:#04x}, expected 0", at,
                                        static_cast<unsigned>(base[at])));
            }
        }
        cursor = end;
    }
    if (cursor != n) {
        throw Error(file, "",
                    fmt::format("{} bytes follow the last section (which ends at byte {}), "
                                "expected none",
                                n - cursor, cursor));
    }
    for (const SectionInfo& s : sections) {
        const std::uint64_t computed = section_checksum(bytes.subspan(s.offset, s.size));
        if (computed != s.checksum) {
            throw Error(file, section_location(s.tag),
                        fmt::format("checksum {:#018x} recorded, {:#018x} computed over its {} "
                                    "bytes: the section is damaged",
                                    s.checksum, computed, s.size));
        }
    }
    return SectionFile(file, std::move(mapping), version, std::move(sections));
}

const SectionInfo* SectionFile::find(std::uint32_t tag) const {
    for (const SectionInfo& s : m_sections) {
        if (s.tag == tag) {
            return &s;
        }
    }
    return nullptr;
}

std::span<const std::byte> SectionFile::bytes(std::uint32_t tag) const {
    const SectionInfo* s = find(tag);
    if (s == nullptr) {
        std::string present;
        for (const SectionInfo& other : m_sections) {
            present += fmt::format("{}'{}'", present.empty() ? "" : ", ", tag_name(other.tag));
        }
        throw Error(m_path, section_location(tag),
                    present.empty() ? std::string("missing (the file has no sections)")
                                    : fmt::format("missing (the file has sections {})", present));
    }
    return m_file.bytes().subspan(s->offset, s->size);
}

void SectionFile::check_array(std::uint32_t tag, std::span<const std::byte> bytes, std::size_t size,
                              std::size_t alignment) const {
    const SectionInfo* s = find(tag);
    if (s->element_size != 0 && s->element_size != size) {
        throw Error(m_path, section_location(tag),
                    fmt::format("holds {}-byte records, read as {}-byte records (the writer and "
                                "reader disagree on the record layout)",
                                s->element_size, size));
    }
    if (bytes.size() % size != 0) {
        throw Error(m_path, section_location(tag),
                    fmt::format("size {} is not a multiple of the {}-byte record it is read as",
                                bytes.size(), size));
    }
    if (reinterpret_cast<std::uintptr_t>(bytes.data()) % alignment != 0) {
        throw Error(m_path, section_location(tag),
                    fmt::format("is not {}-byte aligned as its records need", alignment));
    }
}

}  // namespace mrt
