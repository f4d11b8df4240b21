#pragma once
// The SIMD instruction set of lightskin's vector kernels, chosen at run time.
//
// Everything is compiled for the x86-64 baseline. The vector kernels (the CPU GI backend, the bilateral
// depth filter) are compiled once per instruction set by Highway (foreach_target.h) and the best one that
// the CPU supports is dispatched at run time, so one binary runs on every x86-64 machine and uses the widest
// vectors each one has. The environment variable LIGHTSKIN_SIMD_TARGET caps that choice ("AVX2" = AVX2 or
// an older set): the process then runs the kernels an older CPU would run (docs/TESTING.md).
//
// Names are Highway's target names: "AVX3" (AVX-512), "AVX2", "SSE4", "SSSE3", "SCALAR".
// Not thread-safe against kernels running on other threads: change the target between frames only.

#include <string>
#include <string_view>
#include <vector>

namespace lightskin::core {

/// The environment variable that caps the dispatched instruction set.
inline constexpr const char* kSimdTargetVariable = "LIGHTSKIN_SIMD_TARGET";

/// Instruction sets this build generated and this CPU supports, within the LIGHTSKIN_SIMD_TARGET cap,
/// best first; never empty (the scalar fallback is always there).
std::vector<std::string> simdTargets();

/// The instruction set the kernels dispatch to now (the first of simdTargets() unless restricted).
std::string activeSimdTarget();

/// Applies LIGHTSKIN_SIMD_TARGET once per process; every module with vector kernels calls it before it
/// dispatches. Throws lightskin::Error naming the variable when its value is not a target of this build.
/// A cap above what the CPU supports does not bind: the CPU's best set runs.
void applySimdTargetCap();

/// Makes the kernels dispatch to `name` only (one of simdTargets()); "" restores the default choice.
/// Throws lightskin::Error naming the target when it is not one of simdTargets().
void restrictSimdTarget(std::string_view name);

/// restrictSimdTarget(name) for a scope (tests and benchmarks that run a kernel on every instruction set).
class SimdTargetScope {
public:
    explicit SimdTargetScope(std::string_view name) { restrictSimdTarget(name); }
    ~SimdTargetScope() { restrictSimdTarget(""); }
    SimdTargetScope(const SimdTargetScope&) = delete;
    SimdTargetScope& operator=(const SimdTargetScope&) = delete;
};

} // namespace lightskin::core
