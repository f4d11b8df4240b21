#pragma once
// Bad-input tests: run an action that must throw lightskin::Error, and check what the error names
// (the file or key it is about, the frame, and the cause) rather than only that something was thrown.
#include <lightskin/core/Error.h>

#include <gtest/gtest.h>

#include <cstdint>
#include <optional>
#include <string>

namespace lightskin::test {

struct Expected {
    std::string fileEnds;              ///< Error::source() must end with this
    std::optional<std::int64_t> frame; ///< Error::frame()
    std::string causeContains;         ///< Error::cause() must contain this (case-sensitive)
};

/// Runs `action`, expecting an Error as described.
template <typename Action>
void expectError(Action&& action, const Expected& expected) {
    try {
        action();
        ADD_FAILURE() << "no error; expected one about " << expected.fileEnds << ": " << expected.causeContains;
    } catch (const Error& error) {
        const std::string& source = error.source();
        EXPECT_TRUE(
            source.size() >= expected.fileEnds.size() &&
            source.compare(source.size() - expected.fileEnds.size(), expected.fileEnds.size(), expected.fileEnds) == 0)
            << "source '" << source << "' should end with '" << expected.fileEnds << "' (" << error.what() << ")";
        EXPECT_EQ(error.frame(), expected.frame) << error.what();
        EXPECT_NE(error.cause().find(expected.causeContains), std::string::npos)
            << "cause '" << error.cause() << "' should mention '" << expected.causeContains << "'";
    }
}

} // namespace lightskin::test
