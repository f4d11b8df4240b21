// main() for GL test binaries: a shared headless context and GL error checking per test.
#include "GlTestEnvironment.h"

int main(int argc, char** argv) {
    ::testing::InitGoogleTest(&argc, argv);
    ::testing::AddGlobalTestEnvironment(new lightskin::test::GlTestEnvironment);
    return RUN_ALL_TESTS();
}
