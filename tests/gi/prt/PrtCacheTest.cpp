// Multi-scale PRT's precompute cache (gi/prt/src/PrtCache.cpp): a bitwise round trip, and every kind of bad file
// (missing, truncated anywhere, a flipped byte, another key, inconsistent arrays with a valid checksum) is
// refused with a reason instead of crashing or loading wrong data.
#include "PrtScenes.h"

#include <lightskin/gi/prt/MultiscalePrt.h>

#include <gtest/gtest.h>

#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

namespace lightskin::test {
namespace {

template <class T>
bool bitwiseEqual(const std::vector<T>& a, const std::vector<T>& b) {
    return a.size() == b.size() && (a.empty() || std::memcmp(a.data(), b.data(), a.size() * sizeof(T)) == 0);
}

class PrtCache : public ::testing::Test {
protected:
    void SetUp() override {
        folder_ =
            std::filesystem::temp_directory_path() /
            ("lightskin_prt_cache_" + std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()));
        std::filesystem::remove_all(folder_);
        std::filesystem::create_directories(folder_);
        scene_ = prt::insideBox(2, glm::vec3(0.5f, 0.4f, 0.3f), false);
        settings_.entryPoints = 24;
        settings_.walksPerEntry = 2;
        settings_.clusters = 3;
        settings_.basisVectors = 2;
        settings_.obscuranceDistance = 0.3f;
        settings_.obscuranceRays = 8;
        settings_.keepUncompressed = true;
        data_ = gi::precomputePrt(scene_.instances, settings_);
    }
    void TearDown() override { std::filesystem::remove_all(folder_); }
    std::string bytes(const std::filesystem::path& file) const {
        std::ifstream in(file, std::ios::binary);
        return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
    }
    void write(const std::filesystem::path& file, const std::string& content) const {
        std::ofstream(file, std::ios::binary | std::ios::trunc).write(content.data(), std::streamsize(content.size()));
    }

    std::filesystem::path folder_;
    prt::PrtScene scene_;
    gi::MultiscalePrtSettings settings_;
    gi::PrtData data_;
};

TEST_F(PrtCache, RoundTripIsBitwise) {
    const auto file = folder_ / "a.bin";
    gi::savePrtCache(data_, file);
    EXPECT_FALSE(std::filesystem::exists(folder_ / "a.bin.tmp")) << "the temporary file is renamed into place";
    gi::PrtData loaded;
    std::string reason;
    ASSERT_TRUE(gi::loadPrtCache(file, data_.key, loaded, reason)) << reason;
    EXPECT_EQ(loaded.key, data_.key);
    EXPECT_EQ(loaded.basisVectors, data_.basisVectors);
    EXPECT_EQ(loaded.clusterCount, data_.clusterCount);
    EXPECT_TRUE(bitwiseEqual(loaded.exitOffsets, data_.exitOffsets));
    EXPECT_TRUE(bitwiseEqual(loaded.exitPositions, data_.exitPositions));
    EXPECT_TRUE(bitwiseEqual(loaded.exitNormals, data_.exitNormals));
    EXPECT_TRUE(bitwiseEqual(loaded.exitObscurance, data_.exitObscurance));
    EXPECT_TRUE(bitwiseEqual(loaded.entryPositions, data_.entryPositions));
    EXPECT_TRUE(bitwiseEqual(loaded.entryNormals, data_.entryNormals));
    EXPECT_TRUE(bitwiseEqual(loaded.entryObscurance, data_.entryObscurance));
    EXPECT_TRUE(bitwiseEqual(loaded.entryCluster, data_.entryCluster));
    EXPECT_TRUE(bitwiseEqual(loaded.clusterMaps, data_.clusterMaps));
    EXPECT_TRUE(bitwiseEqual(loaded.entryWeights, data_.entryWeights));
    EXPECT_TRUE(bitwiseEqual(loaded.singularValues, data_.singularValues));
    EXPECT_TRUE(bitwiseEqual(loaded.singularValueOffsets, data_.singularValueOffsets));
    EXPECT_TRUE(bitwiseEqual(loaded.uncompressed, data_.uncompressed));
    EXPECT_FALSE(data_.clusterMaps.empty());
    EXPECT_FALSE(data_.uncompressed.empty());
    // Saving what was loaded gives the same file: nothing is lost or reordered.
    gi::savePrtCache(loaded, folder_ / "b.bin");
    EXPECT_EQ(bytes(file), bytes(folder_ / "b.bin"));
}

TEST_F(PrtCache, TheKeyFollowsMeshesMaterialsPlacementAndSettings) {
    const std::uint64_t key = gi::prtCacheKey(scene_.instances, settings_);
    EXPECT_EQ(key, data_.key);
    prt::PrtScene other = scene_;
    other.instances[1].material.diffuseAlbedo.x += 0.01f;
    EXPECT_NE(gi::prtCacheKey(other.instances, settings_), key);
    other = scene_;
    other.instances[2].world_T_model[3][0] = 0.5f;
    EXPECT_NE(gi::prtCacheKey(other.instances, settings_), key);
    gi::MultiscalePrtSettings s = settings_;
    s.basisVectors = 3;
    EXPECT_NE(gi::prtCacheKey(scene_.instances, s), key);
    s = settings_;
    s.cacheDirectory = "/elsewhere"; // where the cache lives is not what it holds
    EXPECT_EQ(gi::prtCacheKey(scene_.instances, s), key);
}

TEST_F(PrtCache, BadFilesAreRefusedWithAReason) {
    const auto file = folder_ / "a.bin";
    gi::savePrtCache(data_, file);
    const std::string good = bytes(file);
    gi::PrtData out;
    std::string reason;
    EXPECT_FALSE(gi::loadPrtCache(folder_ / "missing.bin", data_.key, out, reason));
    EXPECT_EQ(reason, "no cache file");
    EXPECT_FALSE(gi::loadPrtCache(file, data_.key + 1, out, reason));
    EXPECT_NE(reason.find("key mismatch"), std::string::npos) << reason;

    // Truncated at every length up to the header and at a spread of lengths after it.
    for (std::size_t length = 0; length < good.size(); length += length < 64 ? 1 : 97) {
        write(file, good.substr(0, length));
        EXPECT_FALSE(gi::loadPrtCache(file, data_.key, out, reason)) << "length " << length;
        EXPECT_FALSE(reason.empty());
    }
    // One flipped byte anywhere after the header's key: the checksum (or the header) catches it.
    for (std::size_t at = 20; at < good.size(); at += 61) {
        std::string bad = good;
        bad[at] = char(bad[at] ^ 0x5a);
        write(file, bad);
        EXPECT_FALSE(gi::loadPrtCache(file, data_.key, out, reason)) << "byte " << at;
    }
    write(file, std::string(good.size(), 'x'));
    EXPECT_FALSE(gi::loadPrtCache(file, data_.key, out, reason));
    EXPECT_NE(reason.find("not a PRT cache file"), std::string::npos) << reason;

    // A well-formed file (valid checksum) whose arrays disagree: refused before anything can index them.
    gi::PrtData inconsistent = data_;
    inconsistent.entryCluster[0] = inconsistent.clusterCount; // out of range
    gi::savePrtCache(inconsistent, file);
    EXPECT_FALSE(gi::loadPrtCache(file, data_.key, out, reason));
    EXPECT_NE(reason.find("cluster is out of range"), std::string::npos) << reason;
    inconsistent = data_;
    inconsistent.entryWeights.pop_back();
    gi::savePrtCache(inconsistent, file);
    EXPECT_FALSE(gi::loadPrtCache(file, data_.key, out, reason));
    EXPECT_NE(reason.find("weight"), std::string::npos) << reason;

    // The failed loads left `out` untouched; the good file still loads.
    EXPECT_EQ(out.entryCount(), 0u);
    write(file, good);
    EXPECT_TRUE(gi::loadPrtCache(file, data_.key, out, reason)) << reason;
}

} // namespace
} // namespace lightskin::test
