#pragma once
// Private: the AprilTag families Debian's libapriltag 3.3 ships, owned through RAII.
// Never include from a public header (it pulls in apriltag.h).

#include <apriltag/apriltag.h>

#include <memory>
#include <string>
#include <vector>

namespace lightskin::tracking::detail {

struct FamilyDeleter {
    void (*destroy)(apriltag_family_t*) = nullptr;
    void operator()(apriltag_family_t* family) const noexcept {
        if (family != nullptr && destroy != nullptr) destroy(family);
    }
};

/// Owns one apriltag_family_t (create/destroy pair of the library). A family instance may be
/// given to one detector only (the detector stores its decode table in the family).
using FamilyPtr = std::unique_ptr<apriltag_family_t, FamilyDeleter>;

/// Creates the family `name`; throws lightskin::Error naming the family if the library has none.
FamilyPtr createFamily(const std::string& name);

/// Names createFamily() accepts, in a stable order.
std::vector<std::string> familyNames();

} // namespace lightskin::tracking::detail
