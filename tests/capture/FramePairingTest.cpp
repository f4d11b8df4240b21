// The .oni pairing rule (capture/src/FramePairing.h) on frame-number sequences as OpenNI2's player
// delivers them, with a frame of one stream skipped. The whole source on the real sample (numbers 1..12 on
// both streams, nothing skipped) is OniSourceTest.DeliversEveryFrameInOrderThenEnds: 12 pairs, 0 dropped.
#include "FramePairing.h"

#include <gtest/gtest.h>

#include <utility>
#include <vector>

namespace lightskin::test {
namespace {

using capture::detail::FrameIndexPairing;
using Decision = FrameIndexPairing::Decision;

/// Plays the source's loop: hold the next depth and colour number of each stream, decide, and on a drop
/// take the next number of that stream. Returns the pairs delivered and counts the drops.
std::vector<std::pair<int, int>> pairAll(const std::vector<int>& depth, const std::vector<int>& colour, int& dropped) {
    FrameIndexPairing pairing;
    std::vector<std::pair<int, int>> pairs;
    std::size_t d = 0, c = 0;
    dropped = 0;
    while (d < depth.size() && c < colour.size()) {
        switch (pairing.decide(depth[d], colour[c])) {
        case Decision::Pair:
            pairs.emplace_back(depth[d++], colour[c++]);
            break;
        case Decision::DropDepth:
            ++d;
            ++dropped;
            break;
        case Decision::DropColour:
            ++c;
            ++dropped;
            break;
        }
    }
    return pairs;
}

TEST(FramePairingTest, AlignedStreamsPairEveryFrame) {
    int dropped = 0;
    const auto pairs = pairAll({1, 2, 3, 4}, {1, 2, 3, 4}, dropped);
    EXPECT_EQ(pairs, (std::vector<std::pair<int, int>>{{1, 1}, {2, 2}, {3, 3}, {4, 4}}));
    EXPECT_EQ(dropped, 0);
}

TEST(FramePairingTest, ASkippedColourFrameDropsItsDepthFrameInsteadOfShiftingThePairs) {
    // The case seen in the TSan build: colour 5 -> 7 while depth goes on 6, 7 (docs/TESTING.md).
    int dropped = 0;
    const auto pairs = pairAll({1, 2, 3, 4, 5, 6, 7, 8}, {1, 2, 3, 4, 5, 7, 8}, dropped);
    EXPECT_EQ(pairs, (std::vector<std::pair<int, int>>{{1, 1}, {2, 2}, {3, 3}, {4, 4}, {5, 5}, {7, 7}, {8, 8}}));
    EXPECT_EQ(dropped, 1); // depth 6
}

TEST(FramePairingTest, ASkippedDepthFrameDropsItsColourFrame) {
    int dropped = 0;
    const auto pairs = pairAll({1, 2, 4, 5}, {1, 2, 3, 4, 5}, dropped);
    EXPECT_EQ(pairs, (std::vector<std::pair<int, int>>{{1, 1}, {2, 2}, {4, 4}, {5, 5}}));
    EXPECT_EQ(dropped, 1); // colour 3
}

TEST(FramePairingTest, StreamsNumberedApartKeepTheirFirstOffset) {
    // Colour numbered 100 ahead of depth; colour 103 is skipped, then depth 5.
    int dropped = 0;
    const auto pairs = pairAll({1, 2, 3, 4, 6, 7}, {101, 102, 104, 105, 106, 107}, dropped);
    EXPECT_EQ(pairs, (std::vector<std::pair<int, int>>{{1, 101}, {2, 102}, {4, 104}, {6, 106}, {7, 107}}));
    EXPECT_EQ(dropped, 2); // depth 3, colour 105
}

TEST(FramePairingTest, ResetLearnsTheOffsetAgain) {
    FrameIndexPairing pairing;
    EXPECT_EQ(pairing.decide(1, 1), Decision::Pair);
    EXPECT_EQ(pairing.decide(2, 3), Decision::DropDepth);
    EXPECT_EQ(pairing.decide(3, 2), Decision::DropColour);
    pairing.reset();
    EXPECT_EQ(pairing.decide(2, 3), Decision::Pair); // a new first pair
    EXPECT_EQ(pairing.decide(3, 4), Decision::Pair);
}

} // namespace
} // namespace lightskin::test
