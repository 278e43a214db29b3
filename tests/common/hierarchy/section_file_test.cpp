// The hierarchy file's container: round trips, the byte layout section_file.h specifies
// (restated here independently of the implementation), and refusal of every kind of bad file,
// including thousands of mutated copies of a valid one.

#include "common/hierarchy/section_file.h"

#include "common/system/atomic_file.h"
#include "common/system/error.h"
#include "tests/support/test_support.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <iostream>
#include <iterator>
#include <random>
#include <string>
#include <vector>

namespace mrt {
namespace {

namespace fs = std::filesystem;
using mrt::testing::error_message;
using mrt::testing::ScratchDirectory;

constexpr std::uint32_t kVersion = 7;

// The layout of section_file.h, restated.
constexpr std::size_t kHeaderBytes = 32;
constexpr std::size_t kEntryBytes = 32;
constexpr std::size_t kCountAt = 12;
constexpr std::size_t kFileSizeAt = 16;
constexpr std::size_t kHeaderChecksumAt = 24;
constexpr std::size_t kEntryTag = 0;
constexpr std::size_t kEntryElementSize = 4;
constexpr std::size_t kEntryOffset = 8;
constexpr std::size_t kEntrySize = 16;
constexpr std::size_t kEntryChecksum = 24;
const std::array<unsigned char, 8> kMagic = {0x89, 'M', 'R', 'H', '\r', '\n', 0x1a, '\n'};

constexpr std::uint32_t kNode = section_tag("NODE");
constexpr std::uint32_t kPoints = section_tag("PNTS");
constexpr std::uint32_t kEmpty = section_tag("EMPT");
constexpr std::uint32_t kName = section_tag("NAME");
constexpr std::uint32_t kIndex = section_tag("IDX ");

/// A record with mixed field types and no padding, like the octree's.
struct Node {
    float lo[3];
    float hi[3];
    std::uint32_t child;
    std::uint16_t count;
    std::uint16_t flags;
};
static_assert(sizeof(Node) == 32);

bool operator==(const Node& a, const Node& b) {
    return std::memcmp(&a, &b, sizeof a) == 0;
}

using Bytes = std::vector<std::byte>;

Bytes read_all(const fs::path& file) {
    std::ifstream in(file, std::ios::binary);
    const std::string s{std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
    Bytes b(s.size());
    std::memcpy(b.data(), s.data(), s.size());
    return b;
}

void write_raw(const fs::path& file, std::span<const std::byte> bytes) {
    std::ofstream out(file, std::ios::binary | std::ios::trunc);
    out.write(reinterpret_cast<const char*>(bytes.data()),
              static_cast<std::streamsize>(bytes.size()));
    ASSERT_TRUE(out.good()) << file;
}

Bytes as_bytes(const std::string& s) {
    Bytes b(s.size());
    std::memcpy(b.data(), s.data(), s.size());
    return b;
}

std::uint64_t read64(const Bytes& b, std::size_t at) {
    std::uint64_t v = 0;
    for (int i = 7; i >= 0; --i) {
        v = v << 8 | static_cast<std::uint64_t>(b.at(at + i));
    }
    return v;
}

void put(Bytes& b, std::size_t at, std::uint64_t v, int width) {
    for (int i = 0; i < width; ++i) {
        b.at(at + i) = static_cast<std::byte>(v >> (8 * i));
    }
}

std::uint32_t read32(const Bytes& b, std::size_t at) {
    std::uint32_t v = 0;
    for (int i = 3; i >= 0; --i) {
        v = v << 8 | static_cast<std::uint32_t>(b.at(at + i));
    }
    return v;
}

std::size_t entry(std::size_t i) {
    return kHeaderBytes + kEntryBytes * i;
}

/// Recomputes the header checksum after a test edited the header or table, so that the edit
/// reaches the checks behind the checksum. A table longer than the file is left alone (the
/// reader refuses it before looking at the checksum).
void reseal(Bytes& b) {
    const std::size_t table_end = entry(read32(b, kCountAt));
    if (table_end > b.size()) {
        return;
    }
    const std::span<const std::byte> all(b);
    put(b, kHeaderChecksumAt,
        section_checksum(all.subspan(kHeaderBytes, table_end - kHeaderBytes),
                         section_checksum(all.first(kHeaderChecksumAt))),
        8);
}

/// The contents of the sample file: typed arrays, untyped bytes, an empty section, sizes that
/// need padding.
struct Sample {
    std::vector<Node> nodes;
    std::vector<float> points;
    std::vector<double> empty;
    std::string name = "hello, world!";
    std::vector<std::uint16_t> indices;

    Sample() {
        for (std::uint32_t i = 0; i < 50; ++i) {
            const float f = static_cast<float>(i);
            nodes.push_back({{f, -f, 0.5f * f},
                             {f + 1, 2 - f, f * f},
                             3 * i,
                             static_cast<std::uint16_t>(i),
                             0xBEEF});
        }
        for (int i = 0; i < 37; ++i) {
            points.push_back(0.25f * static_cast<float>(i) - 3.0f);
        }
        indices = {1, 2, 3, 65535, 0};
    }

    void write(const fs::path& file, std::uint32_t version = kVersion) const {
        SectionFileWriter writer(version);
        writer.add_array(kNode, std::span<const Node>(nodes));
        writer.add_array(kPoints, std::span<const float>(points));
        writer.add_array(kEmpty, std::span<const double>(empty));
        writer.add(kName, std::as_bytes(std::span(name)));
        Bytes moved(indices.size() * sizeof(std::uint16_t));
        std::memcpy(moved.data(), indices.data(), moved.size());
        writer.add(kIndex, std::move(moved), sizeof(std::uint16_t));
        writer.write(file);
    }
};

// Offsets of the sample's sections, worked out by hand from the specified layout: the table
// ends at 32 + 5 * 32 = 192; NODE 1600 bytes; PNTS 148; EMPT 0; NAME 13; IDX 10.
constexpr std::uint64_t kSampleOffsets[] = {192, 1792, 1984, 1984, 2048};
constexpr std::uint64_t kSampleSizes[] = {1600, 148, 0, 13, 10};
constexpr std::uint64_t kSampleFileSize = 2058;

/// How `open` treats a file: "" when it is refused with a message that names it, otherwise
/// what went wrong.
std::string refusal_problem(const fs::path& file) {
    try {
        SectionFile::open(file, kVersion);
    } catch (const Error& e) {
        const std::string message = e.what();
        if (message.rfind(file.string() + ": ", 0) != 0) {
            return "message does not start with the file name: " + message;
        }
        if (message.find('\n') != std::string::npos) {
            return "message is not one line: " + message;
        }
        return "";
    } catch (const std::exception& e) {
        return std::string("threw something other than mrt::Error: ") + e.what();
    }
    return "was accepted";
}

/// Writes `bytes` to `file` and checks that the reader refuses them; collects what went wrong
/// (the first few cases in full) in `failures`.
class MutationChecker {
  public:
    explicit MutationChecker(fs::path file) : m_file(std::move(file)) {}

    void check(std::span<const std::byte> bytes, const std::string& what) {
        // A fresh file each time: ext4 flushes a file truncated and rewritten in place to the
        // disk on close, which would make thousands of mutations slow.
        std::filesystem::remove(m_file);
        write_raw(m_file, bytes);
        ++m_count;
        const std::string problem = refusal_problem(m_file);
        if (!problem.empty()) {
            ++m_failures;
            if (m_failures <= 10) {
                ADD_FAILURE() << what << ": " << problem;
            }
        }
    }

    int count() const { return m_count; }
    int failures() const { return m_failures; }

  private:
    fs::path m_file;
    int m_count = 0;
    int m_failures = 0;
};

// ------------------------------------------------------------------------------------- tags

TEST(SectionTag, FirstCharacterIsTheLowestByteSoTheFileSpellsTheName) {
    static_assert(section_tag("NODE") == 0x45444F4Eu);
    std::uint32_t expected = 0;
    std::memcpy(&expected, "PNTS", 4);
    EXPECT_EQ(section_tag("PNTS"), expected);
}

TEST(SectionTag, NamesPrintWithUnprintableBytesEscaped) {
    EXPECT_EQ(tag_name(section_tag("NODE")), "NODE");
    EXPECT_EQ(tag_name(section_tag("IDX ")), "IDX ");
    EXPECT_EQ(tag_name(0u), "\\x00\\x00\\x00\\x00");
    EXPECT_EQ(tag_name(section_tag("a\\'\x7f")), "a\\x5c\\x27\\x7f");
    EXPECT_EQ(tag_name(0xFF0A4141u), "AA\\x0a\\xff");
}

// --------------------------------------------------------------------------------- checksum

Bytes random_bytes(std::size_t n, std::uint64_t seed) {
    std::mt19937_64 rng(seed);
    Bytes b(n);
    for (std::byte& x : b) {
        x = static_cast<std::byte>(rng() >> 56);
    }
    return b;
}

TEST(SectionChecksum, EverySingleBitFlipChangesIt) {
    std::vector<std::size_t> lengths;
    for (std::size_t n = 1; n <= 72; ++n) {
        lengths.push_back(n);
    }
    lengths.insert(lengths.end(), {255, 256, 1000});
    for (const std::size_t n : lengths) {
        Bytes b = random_bytes(n, n);
        const std::uint64_t original = section_checksum(b);
        for (std::size_t bit = 0; bit < 8 * n; ++bit) {
            b[bit / 8] ^= static_cast<std::byte>(1u << (bit % 8));
            ASSERT_NE(section_checksum(b), original) << "length " << n << ", bit " << bit;
            b[bit / 8] ^= static_cast<std::byte>(1u << (bit % 8));
        }
    }
}

TEST(SectionChecksum, ZeroBuffersOfDifferentLengthsDiffer) {
    // Truncation to a zero-padded length or appended zero padding must be seen.
    std::vector<std::uint64_t> sums;
    for (std::size_t n = 0; n <= 300; ++n) {
        sums.push_back(section_checksum(Bytes(n)));
    }
    std::sort(sums.begin(), sums.end());
    EXPECT_EQ(std::adjacent_find(sums.begin(), sums.end()), sums.end());
}

TEST(SectionChecksum, SwappedWordsAndStripesDiffer) {
    Bytes b = random_bytes(128, 1);
    const std::uint64_t original = section_checksum(b);
    Bytes words = b;
    std::swap_ranges(words.begin(), words.begin() + 8, words.begin() + 8);  // two lanes
    EXPECT_NE(section_checksum(words), original);
    Bytes stripes = b;
    std::swap_ranges(stripes.begin(), stripes.begin() + 32, stripes.begin() + 32);  // one lane
    EXPECT_NE(section_checksum(stripes), original);
}

TEST(SectionChecksum, SameForAnyAddressAndChainsFromItsSeed) {
    const Bytes b = random_bytes(517, 2);
    const std::uint64_t expected = section_checksum(b);
    Bytes buffer(b.size() + 16);
    for (std::size_t shift = 0; shift < 16; ++shift) {
        std::copy(b.begin(), b.end(), buffer.begin() + static_cast<std::ptrdiff_t>(shift));
        EXPECT_EQ(section_checksum(std::span(buffer).subspan(shift, b.size())), expected);
    }
    EXPECT_NE(section_checksum(b, 1), expected);
    EXPECT_NE(section_checksum(b, 1), section_checksum(b, 2));
}

TEST(SectionChecksum, ValuesArePartOfTheFileFormat) {
    // Pinned: a different value means files written before no longer open. Changing the
    // function needs a new format version.
    EXPECT_EQ(section_checksum({}), 0x9353dfc8a195f3e2u);
    EXPECT_EQ(section_checksum(as_bytes("NODE")), 0xe0bc57417ad4687eu);
    EXPECT_EQ(section_checksum(random_bytes(1000, 3)), 0x58108b004408eb4eu);
}

// ----------------------------------------------------------------------------- round trips

TEST(SectionFile, RoundTripsSectionsOfDifferentTypesAndSizes) {
    ScratchDirectory dir("mrt_section_file");
    const fs::path file = dir.path() / "sample.mrh";
    const Sample sample;
    sample.write(file);

    const SectionFile f = SectionFile::open(file, kVersion);
    EXPECT_EQ(f.version(), kVersion);
    EXPECT_EQ(f.path().string(), file.string());
    EXPECT_EQ(f.file_size(), fs::file_size(file));

    const std::span<const Node> nodes = f.array<Node>(kNode);
    EXPECT_TRUE(std::equal(nodes.begin(), nodes.end(), sample.nodes.begin(), sample.nodes.end()));
    const std::span<const float> points = f.array<float>(kPoints);
    EXPECT_TRUE(
        std::equal(points.begin(), points.end(), sample.points.begin(), sample.points.end()));
    EXPECT_TRUE(f.array<double>(kEmpty).empty());
    const std::span<const std::byte> name = f.bytes(kName);
    EXPECT_EQ(std::string(reinterpret_cast<const char*>(name.data()), name.size()), sample.name);
    const std::span<const std::uint16_t> indices = f.array<std::uint16_t>(kIndex);
    EXPECT_TRUE(
        std::equal(indices.begin(), indices.end(), sample.indices.begin(), sample.indices.end()));

    ASSERT_EQ(f.sections().size(), 5u);
    const std::uint32_t tags[] = {kNode, kPoints, kEmpty, kName, kIndex};
    const std::uint32_t element_sizes[] = {32, 4, 8, 0, 2};
    for (std::size_t i = 0; i < 5; ++i) {
        const SectionInfo& s = f.sections()[i];
        EXPECT_EQ(s.tag, tags[i]) << i;
        EXPECT_EQ(s.element_size, element_sizes[i]) << i;
        EXPECT_EQ(s.size, kSampleSizes[i]) << i;
        EXPECT_EQ(s.offset, kSampleOffsets[i]) << i;
        EXPECT_EQ(s.offset % 64, 0u) << i;
        EXPECT_EQ(reinterpret_cast<std::uintptr_t>(f.bytes(s.tag).data()) % 64, 0u) << i;
        EXPECT_TRUE(f.has(s.tag));
    }
    EXPECT_FALSE(f.has(section_tag("MISS")));
}

TEST(SectionFile, LayoutIsTheSpecifiedOne) {
    ScratchDirectory dir("mrt_section_file");
    const fs::path file = dir.path() / "sample.mrh";
    const Sample sample;
    sample.write(file);
    const Bytes b = read_all(file);
    ASSERT_EQ(b.size(), kSampleFileSize);
    EXPECT_EQ(std::memcmp(b.data(), kMagic.data(), 8), 0);
    EXPECT_EQ(read32(b, 8), kVersion);
    EXPECT_EQ(read32(b, kCountAt), 5u);
    EXPECT_EQ(read64(b, kFileSizeAt), kSampleFileSize);
    const std::span<const std::byte> all(b);
    EXPECT_EQ(read64(b, kHeaderChecksumAt),
              section_checksum(all.subspan(32, 160), section_checksum(all.first(24))));
    const char* names[] = {"NODE", "PNTS", "EMPT", "NAME", "IDX "};
    std::size_t previous_end = entry(5);
    for (std::size_t i = 0; i < 5; ++i) {
        const std::size_t e = entry(i);
        EXPECT_EQ(std::memcmp(b.data() + e + kEntryTag, names[i], 4), 0) << i;
        const std::uint64_t offset = read64(b, e + kEntryOffset);
        const std::uint64_t size = read64(b, e + kEntrySize);
        EXPECT_EQ(offset, kSampleOffsets[i]);
        EXPECT_EQ(size, kSampleSizes[i]);
        EXPECT_EQ(read64(b, e + kEntryChecksum), section_checksum(all.subspan(offset, size)));
        for (std::size_t at = previous_end; at < offset; ++at) {
            EXPECT_EQ(b[at], std::byte{0}) << "padding byte " << at;
        }
        previous_end = offset + size;
    }
    EXPECT_EQ(read32(b, entry(0) + kEntryElementSize), 32u);
    EXPECT_EQ(std::memcmp(b.data() + kSampleOffsets[0], sample.nodes.data(), 1600), 0);
    EXPECT_EQ(std::memcmp(b.data() + kSampleOffsets[3], sample.name.data(), 13), 0);
    EXPECT_EQ(previous_end, b.size());
}

TEST(SectionFile, WritingTwiceGivesIdenticalBytes) {
    ScratchDirectory dir("mrt_section_file");
    const Sample sample;
    sample.write(dir.path() / "a.mrh");
    sample.write(dir.path() / "b.mrh");
    sample.write(dir.path() / "b.mrh");  // over an existing file
    EXPECT_EQ(read_all(dir.path() / "a.mrh"), read_all(dir.path() / "b.mrh"));
}

TEST(SectionFile, ZeroSectionsMakeAHeaderOnlyFile) {
    ScratchDirectory dir("mrt_section_file");
    const fs::path file = dir.path() / "none.mrh";
    SectionFileWriter(kVersion).write(file);
    EXPECT_EQ(fs::file_size(file), kHeaderBytes);
    const SectionFile f = SectionFile::open(file, kVersion);
    EXPECT_TRUE(f.sections().empty());
    EXPECT_FALSE(f.has(kNode));
    EXPECT_EQ(error_message([&] { f.bytes(kNode); }),
              file.string() + ": section 'NODE': missing (the file has no sections)");
}

TEST(SectionFile, OnlyEmptySectionsAndALargeOne) {
    ScratchDirectory dir("mrt_section_file");
    const fs::path file = dir.path() / "large.mrh";
    const Bytes large = random_bytes((1u << 20) + 3, 4);
    SectionFileWriter writer(kVersion);
    writer.add(section_tag("E1  "), Bytes{});
    writer.add(section_tag("BIG "), std::span<const std::byte>(large));
    writer.add(section_tag("E2  "), Bytes{});
    writer.write(file);
    const SectionFile f = SectionFile::open(file, kVersion);
    EXPECT_TRUE(f.bytes(section_tag("E1  ")).empty());
    EXPECT_TRUE(f.bytes(section_tag("E2  ")).empty());
    const std::span<const std::byte> big = f.bytes(section_tag("BIG "));
    EXPECT_TRUE(std::equal(big.begin(), big.end(), large.begin(), large.end()));
    EXPECT_EQ(f.sections()[2].offset, f.file_size());  // an empty last section ends the file
    EXPECT_EQ(f.file_size() % 64, 0u);
}

TEST(SectionFile, SectionsStayValidAfterTheFileObjectMoves) {
    ScratchDirectory dir("mrt_section_file");
    const fs::path file = dir.path() / "sample.mrh";
    Sample().write(file);
    SectionFile a = SectionFile::open(file, kVersion);
    const std::span<const float> points = a.array<float>(kPoints);
    const SectionFile b = std::move(a);
    EXPECT_EQ(points.data(), b.array<float>(kPoints).data());
    EXPECT_EQ(points[0], -3.0f);
}

// ------------------------------------------------------------------------ accessor refusals

TEST(SectionFile, AccessorsRefuseMissingSectionsAndWrongRecordTypes) {
    ScratchDirectory dir("mrt_section_file");
    const fs::path file = dir.path() / "sample.mrh";
    Sample().write(file);
    const SectionFile f = SectionFile::open(file, kVersion);
    const std::string prefix = file.string() + ": section ";
    EXPECT_EQ(error_message([&] { f.bytes(section_tag("MISS")); }),
              prefix +
                  "'MISS': missing (the file has sections 'NODE', 'PNTS', 'EMPT', 'NAME', "
                  "'IDX ')");
    EXPECT_EQ(error_message([&] { f.array<double>(kNode); }),
              prefix +
                  "'NODE': holds 32-byte records, read as 8-byte records (the writer and "
                  "reader disagree on the record layout)");
    EXPECT_EQ(error_message([&] { f.array<std::uint32_t>(kName); }),
              prefix + "'NAME': size 13 is not a multiple of the 4-byte record it is read as");
    EXPECT_EQ(error_message([&] { f.array<std::uint64_t>(kIndex); }),
              prefix +
                  "'IDX ': holds 2-byte records, read as 8-byte records (the writer and "
                  "reader disagree on the record layout)");
    EXPECT_EQ(f.array<char>(kName).size(), 13u);  // untyped: any record that divides the size
}

// ------------------------------------------------------------------------- writer refusals

TEST(SectionFileWriter, RefusesDuplicateTagsAndPartialRecords) {
    SectionFileWriter writer(kVersion);
    writer.add(kNode, Bytes(32), 32);
    EXPECT_EQ(error_message([&] { writer.add(kNode, Bytes(0)); }),
              "section 'NODE' added twice to a hierarchy file");
    EXPECT_EQ(error_message([&] { writer.add(kPoints, Bytes(10), 4); }),
              "section 'PNTS': 10 bytes are not a whole number of 4-byte records");
}

/// The names in `dir`, for checking that nothing was left behind.
std::vector<std::string> listing(const fs::path& dir) {
    std::vector<std::string> names;
    for (const fs::directory_entry& e : fs::directory_iterator(dir)) {
        names.push_back(e.path().filename().string());
    }
    std::sort(names.begin(), names.end());
    return names;
}

TEST(SectionFileWriter, FailedWriteNamesTheFileAndLeavesNoTemporary) {
    ScratchDirectory dir("mrt_section_file");
    // Into a directory that does not exist.
    const fs::path nowhere = dir.path() / "missing" / "out.mrh";
    SectionFileWriter writer(kVersion);
    writer.add(kNode, Bytes(64));
    const std::string message = error_message([&] { writer.write(nowhere); });
    EXPECT_EQ(message.rfind(nowhere.string() + ": cannot write the hierarchy file: ", 0), 0u)
        << message;
    // Over a directory: the temporary is written completely, then the rename fails and the
    // temporary must be removed. Works as root too.
    const fs::path occupied = dir.path() / "occupied.mrh";
    fs::create_directory(occupied);
    const std::string over_directory = error_message([&] { writer.write(occupied); });
    EXPECT_EQ(over_directory.rfind(occupied.string() + ": cannot write the hierarchy file: ", 0),
              0u)
        << over_directory;
    EXPECT_EQ(listing(dir.path()), std::vector<std::string>{"occupied.mrh"});
    EXPECT_TRUE(fs::is_empty(occupied));
}

TEST(SectionFileWriter, UnwritableDirectoryLeavesNothing) {
    if (::geteuid() == 0) {
        GTEST_SKIP() << "running as root, which ignores directory permissions";
    }
    ScratchDirectory dir("mrt_section_file");
    const fs::path locked = dir.path() / "locked";
    fs::create_directory(locked);
    fs::permissions(locked, fs::perms::owner_read | fs::perms::owner_exec);
    SectionFileWriter writer(kVersion);
    writer.add(kNode, Bytes(64));
    const std::string message = error_message([&] { writer.write(locked / "out.mrh"); });
    fs::permissions(locked, fs::perms::owner_all);
    EXPECT_NE(message.find((locked / "out.mrh").string() + ": cannot write the hierarchy file"),
              std::string::npos)
        << message;
    EXPECT_TRUE(fs::is_empty(locked));
}

TEST(AtomicFile, BinaryPiecesAreConcatenatedAndTextStillWorks) {
    ScratchDirectory dir("mrt_section_file");
    const Bytes a = as_bytes("ab\0\r\n"), c = as_bytes(
                                              "\x1a"
                                              "cdef");
    const std::span<const std::byte> pieces[] = {a, {}, c};
    write_file_atomically(dir.path() / "pieces.bin", pieces, "test file");
    Bytes expected = a;
    expected.insert(expected.end(), c.begin(), c.end());
    EXPECT_EQ(read_all(dir.path() / "pieces.bin"), expected);
    write_file_atomically(dir.path() / "text.txt", std::string("line\n"), "test file");
    EXPECT_EQ(read_all(dir.path() / "text.txt"), as_bytes("line\n"));
    EXPECT_EQ(listing(dir.path()), (std::vector<std::string>{"pieces.bin", "text.txt"}));
}

// ---------------------------------------------------------------------- reader refusals

std::string open_error(const fs::path& file) {
    return error_message([&] { SectionFile::open(file, kVersion); });
}

TEST(SectionFile, RefusesMissingEmptyAndNonRegularFiles) {
    ScratchDirectory dir("mrt_section_file");
    const fs::path missing = dir.path() / "missing.mrh";
    EXPECT_EQ(open_error(missing),
              missing.string() + ": cannot be opened: No such file or directory");
    const fs::path empty = dir.path() / "empty.mrh";
    write_raw(empty, {});
    EXPECT_EQ(open_error(empty),
              empty.string() + ": is empty (0 bytes), expected an mrtrace hierarchy file");
    EXPECT_EQ(open_error(dir.path()),
              dir.path().string() + ": is a directory, expected an mrtrace hierarchy file");
}

TEST(SectionFile, RefusesForeignFiles) {
    ScratchDirectory dir("mrt_section_file");
    const fs::path png = dir.path() / "image.png";
    write_raw(png, as_bytes(std::string("\x89PNG\r\n\x1a\n\0\0\0\rIHDR", 16)));
    EXPECT_EQ(open_error(png), png.string() +
                                   ": not an mrtrace hierarchy file: it starts with 89 50 4e 47 "
                                   "0d 0a 1a 0a, expected the magic number 89 4d 52 48 0d 0a 1a "
                                   "0a (\"\\x89MRH\\r\\n\\x1a\\n\")");
    const fs::path text = dir.path() / "scene.json";
    write_raw(text, as_bytes("{\"camera\": {}}\n"));
    EXPECT_NE(open_error(text).find(text.string() + ": not an mrtrace hierarchy file"),
              std::string::npos);
    const fs::path tiny = dir.path() / "tiny.mrh";
    write_raw(tiny, as_bytes("M"));
    EXPECT_NE(open_error(tiny).find(tiny.string() + ": not an mrtrace hierarchy file"),
              std::string::npos);
}

TEST(SectionFile, RefusesAFileDamagedByATextModeTransfer) {
    ScratchDirectory dir("mrt_section_file");
    const fs::path file = dir.path() / "sample.mrh";
    Sample().write(file);
    Bytes b = read_all(file);
    b.erase(b.begin() + 4);  // CR LF -> LF
    write_raw(file, b);
    EXPECT_EQ(open_error(file), file.string() +
                                    ": header: the magic number is damaged: bytes 4 to 7 are 0a "
                                    "1a 0a 07, expected 0d 0a 1a 0a (was the file transferred "
                                    "in text mode?)");
}

TEST(SectionFile, RefusesAnotherVersionNamingBoth) {
    ScratchDirectory dir("mrt_section_file");
    const fs::path file = dir.path() / "old.mrh";
    Sample().write(file, 3);
    EXPECT_EQ(open_error(file), file.string() +
                                    ": header: format version 3 found, version 7 expected "
                                    "(rebuild the file with this mrtrace's mrt-preprocess)");
    EXPECT_EQ(SectionFile::open(file, 3).version(), 3u);
}

/// A copy of the sample's bytes with an edited table, resealed, and the message it must give.
struct TableEdit {
    std::string what;
    std::size_t at;
    std::uint64_t value;
    int width;
    std::string expected;  ///< The message after "FILE: ".
};

TEST(SectionFile, RefusesTablesThatPointOutsideOverlapOrOverflow) {
    ScratchDirectory dir("mrt_section_file");
    const fs::path file = dir.path() / "sample.mrh";
    Sample().write(file);
    const Bytes original = read_all(file);
    const std::uint64_t max = ~std::uint64_t{0};
    const std::vector<TableEdit> edits = {
        {"offset past the end", entry(1) + kEntryOffset, 2112, 8,
         "section 'PNTS': bytes 2112 to 2260 lie outside the 2058-byte file"},
        {"size past the end", entry(4) + kEntrySize, std::uint64_t{1} << 40, 8,
         "section 'IDX ': bytes 2048 to 1099511629824 lie outside the 2058-byte file"},
        {"size overflowing", entry(0) + kEntrySize, max - 63, 8,
         "section 'NODE': offset 192 + size 18446744073709551552 overflows a 64-bit file "
         "position"},
        {"offset overflowing", entry(1) + kEntryOffset, max - 63, 8,
         "section 'PNTS': offset 18446744073709551552 + size 148 overflows a 64-bit file "
         "position"},
        {"offset into the header", entry(3) + kEntryOffset, 0, 8,
         "section 'NAME': offset 0 overlaps the header and section table, which end at byte 192"},
        {"offset into the table", entry(0) + kEntryOffset, 128, 8,
         "section 'NODE': offset 128 overlaps the header and section table, which end at byte "
         "192"},
        {"offset overlapping the previous section", entry(1) + kEntryOffset, 1728, 8,
         "section 'PNTS': bytes 1728 to 1876 overlap section 'NODE', which ends at byte 1792"},
        {"offset not aligned", entry(1) + kEntryOffset, 1793, 8,
         "section 'PNTS': offset 1793 is not a multiple of 64"},
        {"gap before a section", entry(2) + kEntryOffset, 2048, 8,
         "section 'EMPT': offset 2048, expected 1984 (sections follow each other in table order, "
         "each at the next multiple of 64)"},
        {"partial record", entry(0) + kEntryElementSize, 48, 4,
         "section 'NODE': size 1600 is not a multiple of its 48-byte element size"},
        {"duplicate tag", entry(4) + kEntryTag, kNode, 4,
         "section 'NODE': appears twice in the section table (entries 0 and 4), expected once"},
        {"damaged section checksum", entry(1) + kEntryChecksum, 12345, 8,
         "section 'PNTS': checksum 0x0000000000003039 recorded, "},
        {"file size too large", kFileSizeAt, kSampleFileSize + 64, 8,
         "header: truncated: the file has 2058 bytes, its header records 2122"},
        {"file size too small", kFileSizeAt, kSampleFileSize - 10, 8,
         "header: extended: the file has 2058 bytes, its header records 2048"},
        {"huge section count", kCountAt, 0xFFFFFFFFu, 4,
         "section table: truncated: 4294967295 sections need a table ending at byte "
         "137438953472, the file has 2058 bytes"},
        {"one section dropped", kCountAt, 4, 4,
         "section 'NODE': padding byte 160 before it is 0x49, expected 0"},
    };
    for (const TableEdit& edit : edits) {
        Bytes b = original;
        put(b, edit.at, edit.value, edit.width);
        reseal(b);
        write_raw(file, b);
        const std::string message = open_error(file);
        EXPECT_EQ(message.rfind(file.string() + ": " + edit.expected, 0), 0u)
            << edit.what << ": " << message;
    }
}

TEST(SectionFile, RefusesDamagedSectionsAndTrailingBytes) {
    ScratchDirectory dir("mrt_section_file");
    const fs::path file = dir.path() / "sample.mrh";
    Sample().write(file);
    const Bytes original = read_all(file);
    Bytes b = original;
    b[kSampleOffsets[1] + 5] ^= std::byte{0x10};
    write_raw(file, b);
    const std::string damaged = open_error(file);
    EXPECT_EQ(damaged.rfind(file.string() + ": section 'PNTS': checksum 0x", 0), 0u) << damaged;
    EXPECT_NE(damaged.find("computed over its 148 bytes: the section is damaged"),
              std::string::npos)
        << damaged;

    b = original;
    b.push_back(std::byte{0});
    put(b, kFileSizeAt, b.size(), 8);
    reseal(b);
    write_raw(file, b);
    EXPECT_EQ(open_error(file), file.string() +
                                    ": 1 bytes follow the last section (which ends at byte "
                                    "2058), expected none");
}

// ---------------------------------------------------------------------------------- mutations

TEST(SectionFileMutations, EveryTruncationIsRefused) {
    ScratchDirectory dir("mrt_section_file");
    const fs::path file = dir.path() / "sample.mrh";
    Sample().write(file);
    const Bytes original = read_all(file);
    MutationChecker checker(dir.path() / "mutated.mrh");
    // Every length, so every section boundary, every byte of header and table and every payload
    // byte; and longer files (appended zeros and garbage).
    for (std::size_t n = 0; n < original.size(); ++n) {
        checker.check(std::span(original).first(n), "truncated to " + std::to_string(n));
    }
    for (const std::size_t extra : {1, 6, 64, 4096}) {
        Bytes longer = original;
        longer.resize(original.size() + extra);
        checker.check(longer, std::to_string(extra) + " zero bytes appended");
        std::fill(longer.begin() + static_cast<std::ptrdiff_t>(original.size()), longer.end(),
                  std::byte{0xA5});
        checker.check(longer, std::to_string(extra) + " bytes of garbage appended");
    }
    std::cout << "[          ] " << checker.count() << " truncated or extended files refused\n";
    EXPECT_EQ(checker.failures(), 0);
}

TEST(SectionFileMutations, EverySingleBitFlipIsRefused) {
    ScratchDirectory dir("mrt_section_file");
    const fs::path file = dir.path() / "sample.mrh";
    Sample().write(file);
    Bytes b = read_all(file);
    MutationChecker checker(dir.path() / "mutated.mrh");
    // Every bit of the file: header, table, padding and payload.
    for (std::size_t bit = 0; bit < 8 * b.size(); ++bit) {
        const auto mask = static_cast<std::byte>(1u << (bit % 8));
        b[bit / 8] ^= mask;
        checker.check(b, "bit " + std::to_string(bit % 8) + " of byte " + std::to_string(bit / 8));
        b[bit / 8] ^= mask;
    }
    std::cout << "[          ] " << checker.count() << " single-bit flips refused\n";
    EXPECT_EQ(checker.failures(), 0);
}

TEST(SectionFileMutations, RandomByteDamageIsRefused) {
    ScratchDirectory dir("mrt_section_file");
    const fs::path file = dir.path() / "sample.mrh";
    Sample().write(file);
    const Bytes original = read_all(file);
    MutationChecker checker(dir.path() / "mutated.mrh");
    std::mt19937_64 rng(20030623);  // fixed: the same schedule on every run and platform
    // Every header and table byte replaced by a different random value, then bursts of 1 to 16
    // random bytes at random positions anywhere.
    for (std::size_t at = 0; at < entry(5); ++at) {
        Bytes b = original;
        b[at] ^= static_cast<std::byte>(1 + rng() % 255);
        checker.check(b, "byte " + std::to_string(at) + " replaced");
    }
    for (int i = 0; i < 1500; ++i) {
        Bytes b = original;
        const std::size_t length = 1 + rng() % 16;
        const std::size_t at = rng() % (b.size() - length);
        for (std::size_t k = 0; k < length; ++k) {
            b[at + k] ^= static_cast<std::byte>(1 + rng() % 255);
        }
        checker.check(b, std::to_string(length) + " bytes damaged at " + std::to_string(at));
    }
    std::cout << "[          ] " << checker.count() << " files with damaged bytes refused\n";
    EXPECT_EQ(checker.failures(), 0);
}

TEST(SectionFileMutations, HostileOffsetsAndSizesAreRefused) {
    // Every offset and size field set to values chosen to break careless arithmetic, with the
    // header checksum recomputed so they reach the checks that must catch them.
    ScratchDirectory dir("mrt_section_file");
    const fs::path file = dir.path() / "sample.mrh";
    Sample().write(file);
    const Bytes original = read_all(file);
    MutationChecker checker(dir.path() / "mutated.mrh");
    const std::uint64_t max = ~std::uint64_t{0};
    const std::uint64_t n = original.size();
    std::mt19937_64 rng(1999);
    std::vector<std::uint64_t> values = {0,       1,           63,       64,
                                         128,     192,         n - 1,    n,
                                         n + 1,   n + 64,      1u << 31, std::uint64_t{1} << 32,
                                         max / 2, max / 2 + 1, max - 64, max - 63,
                                         max - 1, max,         max - n,  max - 191};
    for (int i = 0; i < 8; ++i) {
        values.push_back(rng());
        values.push_back((rng() % (n + 128)) & ~std::uint64_t{63});
    }
    for (std::size_t section = 0; section < 5; ++section) {
        for (const std::size_t field : {kEntryOffset, kEntrySize}) {
            for (const std::uint64_t v : values) {
                if (v == read64(original, entry(section) + field)) {
                    continue;
                }
                Bytes b = original;
                put(b, entry(section) + field, v, 8);
                reseal(b);
                checker.check(b, "section " + std::to_string(section) + " field " +
                                     std::to_string(field) + " = " + std::to_string(v));
            }
        }
    }
    std::cout << "[          ] " << checker.count() << " hostile tables refused\n";
    EXPECT_EQ(checker.failures(), 0);
}

TEST(SectionFileMutations, SampledDamageInALargeSectionIsRefused) {
    // A section of many checksum stripes: damage and truncation at sampled positions.
    ScratchDirectory dir("mrt_section_file");
    const fs::path file = dir.path() / "large.mrh";
    const Bytes large = random_bytes(300000, 5);
    SectionFileWriter writer(kVersion);
    writer.add(section_tag("HEAD"), std::span<const std::byte>(large).first(100));
    writer.add(section_tag("BIG "), std::span<const std::byte>(large));
    writer.write(file);
    const Bytes original = read_all(file);
    MutationChecker checker(dir.path() / "mutated.mrh");
    std::mt19937_64 rng(42);
    for (int i = 0; i < 100; ++i) {
        Bytes b = original;
        const std::size_t at = rng() % b.size();
        b[at] ^= static_cast<std::byte>(1u << (rng() % 8));
        checker.check(b, "bit flipped in byte " + std::to_string(at));
        checker.check(std::span(original).first(rng() % original.size()), "truncated");
    }
    std::cout << "[          ] " << checker.count() << " damaged large files refused\n";
    EXPECT_EQ(checker.failures(), 0);
}

}  // namespace
}  // namespace mrt
