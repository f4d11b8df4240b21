#pragma once
// Comma-separated option values of the `lightskin bench*` commands ("64,256,1024"), parsed alike by
// the commands (apps/lightskin) and the benchmarks.
#include <algorithm>
#include <cstddef>
#include <string>
#include <vector>

namespace lightskin::bench {

/// Splits a comma-separated option value ("64,256,1024") and parses each non-empty item with
/// `parse` (which throws on a bad item).
template <typename T, typename Parse>
std::vector<T> splitList(const std::string& text, Parse parse) {
    std::vector<T> out;
    std::size_t start = 0;
    while (start <= text.size()) {
        const std::size_t end = std::min(text.find(',', start), text.size());
        if (end > start) out.push_back(parse(text.substr(start, end - start)));
        start = end + 1;
    }
    return out;
}

} // namespace lightskin::bench
