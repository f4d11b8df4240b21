# Every third-party dependency, found once, from Debian's packages (scripts/install_dependencies.sh).
# Modules link the imported targets below; nothing is vendored.
find_package(PkgConfig REQUIRED)
find_package(Threads REQUIRED)

find_package(OpenCV 4.5 REQUIRED COMPONENTS core imgproc imgcodecs calib3d videoio quality rgbd)
find_package(PNG REQUIRED) # the recorder's PNG encoder (capture/src/PngEncoder.h)
find_package(glm REQUIRED)
find_package(spdlog REQUIRED)
find_package(fmt REQUIRED)
find_package(nlohmann_json 3.10 REQUIRED)
find_package(CLI11 REQUIRED)
find_package(glfw3 3.3 REQUIRED)

pkg_check_modules(EPOXY REQUIRED IMPORTED_TARGET epoxy)
pkg_check_modules(EGL REQUIRED IMPORTED_TARGET egl)
pkg_check_modules(APRILTAG REQUIRED IMPORTED_TARGET apriltag)
pkg_check_modules(OPENNI2 REQUIRED IMPORTED_TARGET libopenni2)
pkg_check_modules(FREENECT REQUIRED IMPORTED_TARGET libfreenect)

# PCL is heavy to parse and to include: only the components we use, and only in .cpp files.
find_package(PCL 1.12 REQUIRED COMPONENTS common search kdtree features)
add_library(lightskin_pcl INTERFACE)
target_include_directories(lightskin_pcl SYSTEM INTERFACE ${PCL_INCLUDE_DIRS})
# Only the PCL libraries we call: PCL_LIBRARIES would drag VTK and Qt into every link.
target_link_libraries(lightskin_pcl INTERFACE ${PCL_COMMON_LIBRARIES} ${PCL_SEARCH_LIBRARIES} ${PCL_KDTREE_LIBRARIES}
  ${PCL_FEATURES_LIBRARIES} FLANN::FLANN)

find_package(embree 3 REQUIRED)
# Multi-scale PRT's clustered PCA (gi/prt/src/PrtPrecompute.cpp): header-only.
find_package(Eigen3 3.3 REQUIRED NO_MODULE)
find_package(assimp REQUIRED)
# CPU backend of the GI core (gi::CpuLightSkin): portable SIMD with runtime dispatch, threads.
find_package(hwy REQUIRED)
find_package(OpenMP REQUIRED COMPONENTS CXX)
# The CPU backend's thread pool (oneTBB: idle workers sleep; libgomp's spin between regions cost
# 30 % of the replay's CPU, docs/BENCHMARKS.md). OpenMP stays available to the gi module.
find_package(TBB REQUIRED)

if(LIGHTSKIN_BUILD_TESTS)
  find_package(GTest REQUIRED)
  include(GoogleTest)
endif()
if(LIGHTSKIN_BUILD_BENCHMARKS)
  find_package(benchmark REQUIRED)
endif()
