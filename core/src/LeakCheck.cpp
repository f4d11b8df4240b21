#include <lightskin/core/LeakCheck.h>

#if defined(__has_feature)
#if __has_feature(address_sanitizer) || __has_feature(leak_sanitizer)
#define LIGHTSKIN_HAS_LEAK_SANITIZER 1
#endif
#endif
#if defined(__SANITIZE_ADDRESS__)
#define LIGHTSKIN_HAS_LEAK_SANITIZER 1
#endif

#if defined(LIGHTSKIN_HAS_LEAK_SANITIZER)
#include <dlfcn.h>
#include <link.h>
#include <string>
#include <vector>
#endif

namespace lightskin::sanitizer {

#if defined(LIGHTSKIN_HAS_LEAK_SANITIZER)
void keepLoadedModulesMapped() {
    std::vector<std::string> paths;
    dl_iterate_phdr(
        [](dl_phdr_info* info, std::size_t, void* out) {
            // The main program and the vDSO have no path (or a pseudo one) and are never unloaded.
            if (info->dlpi_name != nullptr && info->dlpi_name[0] == '/')
                static_cast<std::vector<std::string>*>(out)->emplace_back(info->dlpi_name);
            return 0;
        },
        &paths);
    // RTLD_NOLOAD: only objects that are already loaded; RTLD_NODELETE: a later dlclose (by anyone, including
    // the reference taken here, which is deliberately never released) leaves them mapped.
    for (const std::string& path : paths) dlopen(path.c_str(), RTLD_LAZY | RTLD_NOLOAD | RTLD_NODELETE);
}
#else
void keepLoadedModulesMapped() {}
#endif

} // namespace lightskin::sanitizer
