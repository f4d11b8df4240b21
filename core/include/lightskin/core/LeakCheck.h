#pragma once
// Support for LeakSanitizer in sanitizer builds (scripts/sanitize.sh, LIGHTSKIN_SANITIZE=ON).

namespace lightskin::sanitizer {

/// Keeps every shared object loaded so far mapped until the process exits (RTLD_NODELETE), in builds
/// with AddressSanitizer or LeakSanitizer; does nothing in other builds.
///
/// Call it right after a third-party library has loaded its driver modules (eglInitialize loads Mesa's
/// DRI driver and LLVM; OpenNI::initialize loads OpenNI2/Drivers/*.so). Those libraries dlclose the
/// modules on eglTerminate / OpenNI::shutdown, but LeakSanitizer checks at exit: a leak allocated in an
/// unmapped module shows up as an unnamed address (or is blamed on whatever is mapped there now), so no
/// suppression can match it precisely. Kept mapped, its frames name the module and function, and
/// cmake/sanitizers/lsan.supp suppresses exactly those. Thread-safe; cheap enough to call per context.
void keepLoadedModulesMapped();

} // namespace lightskin::sanitizer
