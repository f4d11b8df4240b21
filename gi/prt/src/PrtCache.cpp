// Multi-scale PRT precompute cache: one binary file per key. Layout (little-endian, this machine's floats):
//   "LSKPRT\r\n" | u32 format | u64 key | u64 payload bytes | payload | u64 FNV-1a of the payload
// payload = the PrtData arrays, each as u64 element count + raw elements, then the scalars. Every read is
// bounds-checked and the arrays' sizes are checked against each other, so no byte sequence can make the
// technique index out of range later.
#include <lightskin/core/Error.h>
#include <lightskin/gi/prt/MultiscalePrt.h>

#include <cstring>
#include <fstream>
#include <string>
#include <system_error>

namespace lightskin::gi {
namespace {

constexpr char kMagic[8] = {'L', 'S', 'K', 'P', 'R', 'T', '\r', '\n'};
constexpr std::uint32_t kFileFormat = 1;

std::uint64_t fnv(const char* data, std::size_t size) {
    std::uint64_t h = 0xcbf29ce484222325ull;
    for (std::size_t i = 0; i < size; ++i) h = (h ^ static_cast<unsigned char>(data[i])) * 0x100000001b3ull;
    return h;
}

struct Writer {
    std::string bytes;
    template <class T>
    void pod(const T& v) {
        bytes.append(reinterpret_cast<const char*>(&v), sizeof v);
    }
    template <class T>
    void array(const std::vector<T>& v) {
        pod(std::uint64_t(v.size()));
        bytes.append(reinterpret_cast<const char*>(v.data()), v.size() * sizeof(T));
    }
};

struct Reader {
    const char* data;
    std::size_t size, at = 0;
    bool ok = true;
    template <class T>
    T pod() {
        T v{};
        if (size - at < sizeof v) {
            ok = false;
            return v;
        }
        std::memcpy(&v, data + at, sizeof v);
        at += sizeof v;
        return v;
    }
    template <class T>
    void array(std::vector<T>& v) {
        const auto count = pod<std::uint64_t>();
        if (!ok || count > (size - at) / sizeof(T)) {
            ok = false;
            return;
        }
        v.resize(std::size_t(count));
        if (count == 0) return; // an empty vector's data() may be null, which memcpy must not get
        std::memcpy(v.data(), data + at, std::size_t(count) * sizeof(T));
        at += std::size_t(count) * sizeof(T);
    }
};

// The relations prtEntryIrradianceInto / prtExitIrradianceInto / the technique rely on.
bool consistent(const PrtData& d, std::string& reason) {
    const std::size_t X = d.exitCount(), E = d.entryCount(), D = std::size_t(d.basisVectors);
    const auto fail = [&](const char* what) {
        reason = what;
        return false;
    };
    if (d.basisVectors < 0 || d.basisVectors > 64) return fail("basis vector count out of range");
    if (d.exitNormals.size() != X || d.exitObscurance.size() != X) return fail("exit arrays of different lengths");
    if (d.entryNormals.size() != E || d.entryObscurance.size() != E || d.entryCluster.size() != E)
        return fail("entry arrays of different lengths");
    if (d.exitOffsets.empty() || d.exitOffsets.back() != X) return fail("exit offsets do not end at the exit count");
    for (std::size_t i = 1; i < d.exitOffsets.size(); ++i)
        if (d.exitOffsets[i] < d.exitOffsets[i - 1]) return fail("exit offsets not ascending");
    for (std::uint32_t c : d.entryCluster)
        if (c >= d.clusterCount) return fail("an entry's cluster is out of range");
    if (d.clusterMaps.size() != std::size_t(d.clusterCount) * (D + 1) * 3 * X) return fail("cluster map size mismatch");
    if (d.entryWeights.size() != E * D) return fail("entry weight count mismatch");
    if (d.singularValueOffsets.size() != std::size_t(d.clusterCount) + 1 ||
        d.singularValueOffsets.back() != d.singularValues.size())
        return fail("singular value offsets mismatch");
    if (!d.uncompressed.empty() && d.uncompressed.size() != E * 3 * X)
        return fail("uncompressed transfer size mismatch");
    return true;
}

} // namespace

void savePrtCache(const PrtData& data, const std::filesystem::path& file) {
    Writer payload;
    payload.array(data.exitOffsets);
    payload.array(data.exitPositions);
    payload.array(data.exitNormals);
    payload.array(data.exitObscurance);
    payload.array(data.entryPositions);
    payload.array(data.entryNormals);
    payload.array(data.entryObscurance);
    payload.array(data.entryCluster);
    payload.array(data.clusterMaps);
    payload.array(data.entryWeights);
    payload.array(data.singularValues);
    payload.array(data.singularValueOffsets);
    payload.array(data.uncompressed);
    payload.pod(std::int32_t(data.basisVectors));
    payload.pod(data.clusterCount);
    payload.pod(data.precomputeSeconds);

    Writer head;
    head.bytes.append(kMagic, sizeof kMagic);
    head.pod(kFileFormat);
    head.pod(data.key);
    head.pod(std::uint64_t(payload.bytes.size()));
    const std::uint64_t checksum = fnv(payload.bytes.data(), payload.bytes.size());

    std::error_code error;
    if (!file.parent_path().empty()) std::filesystem::create_directories(file.parent_path(), error);
    if (error)
        throw Error(file.parent_path().string(), std::nullopt, "cannot create the cache folder: " + error.message());
    std::filesystem::path temporary = file;
    temporary += ".tmp";
    {
        std::ofstream out(temporary, std::ios::binary | std::ios::trunc);
        if (!out) throw Error(temporary.string(), std::nullopt, "cannot write the PRT cache file");
        out.write(head.bytes.data(), std::streamsize(head.bytes.size()));
        out.write(payload.bytes.data(), std::streamsize(payload.bytes.size()));
        out.write(reinterpret_cast<const char*>(&checksum), sizeof checksum);
        out.close();
        if (!out) {
            std::filesystem::remove(temporary, error);
            throw Error(temporary.string(), std::nullopt, "writing the PRT cache file failed (disk full?)");
        }
    }
    std::filesystem::rename(temporary, file, error);
    if (error) {
        std::filesystem::remove(temporary, error);
        throw Error(file.string(), std::nullopt, "cannot move the PRT cache file into place");
    }
}

bool loadPrtCache(const std::filesystem::path& file, std::uint64_t expectedKey, PrtData& out, std::string& reason) {
    std::ifstream in(file, std::ios::binary);
    if (!in) {
        reason = "no cache file";
        return false;
    }
    std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    Reader header{bytes.data(), bytes.size()};
    char magic[8];
    for (char& m : magic) m = header.pod<char>();
    const auto format = header.pod<std::uint32_t>();
    const auto key = header.pod<std::uint64_t>();
    const auto payloadSize = header.pod<std::uint64_t>();
    if (!header.ok || std::memcmp(magic, kMagic, sizeof kMagic) != 0) {
        reason = "not a PRT cache file (bad or truncated header)";
        return false;
    }
    if (format != kFileFormat) {
        reason = "cache file format " + std::to_string(format) + ", this build reads " + std::to_string(kFileFormat);
        return false;
    }
    if (key != expectedKey) {
        reason = "the cache holds another scene or settings (key mismatch)";
        return false;
    }
    if (payloadSize != bytes.size() - header.at - sizeof(std::uint64_t) || bytes.size() < header.at + 8) {
        reason = "truncated (" + std::to_string(bytes.size()) + " bytes, the header announces " +
                 std::to_string(payloadSize) + " bytes of data)";
        return false;
    }
    std::uint64_t checksum = 0;
    std::memcpy(&checksum, bytes.data() + bytes.size() - sizeof checksum, sizeof checksum);
    if (checksum != fnv(bytes.data() + header.at, std::size_t(payloadSize))) {
        reason = "corrupt (checksum mismatch)";
        return false;
    }
    PrtData d;
    Reader r{bytes.data() + header.at, std::size_t(payloadSize)};
    r.array(d.exitOffsets);
    r.array(d.exitPositions);
    r.array(d.exitNormals);
    r.array(d.exitObscurance);
    r.array(d.entryPositions);
    r.array(d.entryNormals);
    r.array(d.entryObscurance);
    r.array(d.entryCluster);
    r.array(d.clusterMaps);
    r.array(d.entryWeights);
    r.array(d.singularValues);
    r.array(d.singularValueOffsets);
    r.array(d.uncompressed);
    d.basisVectors = r.pod<std::int32_t>();
    d.clusterCount = r.pod<std::uint32_t>();
    d.precomputeSeconds = r.pod<double>();
    if (!r.ok || r.at != r.size) {
        reason = "corrupt (the arrays do not fill the announced size)";
        return false;
    }
    if (!consistent(d, reason)) {
        reason = "corrupt (" + reason + ")";
        return false;
    }
    d.key = key;
    out = std::move(d);
    return true;
}

} // namespace lightskin::gi
