#include <lightskin/core/Error.h>
#include <lightskin/gl/ShaderLibrary.h>

#include <algorithm>

namespace lightskin::gl {

ShaderLibrary::ShaderLibrary(std::initializer_list<std::span<const EmbeddedFile>> tables) : tables_(tables) {
    tables_.push_back(embeddedShaders());
}

std::string_view ShaderLibrary::raw(std::string_view name) const {
    for (const auto& table : tables_)
        for (const EmbeddedFile& file : table)
            if (file.name == name) return file.contents;
    throw Error(std::string(name), std::nullopt, "no such embedded shader (is it listed in lightskin_embed_shaders?)");
}

void ShaderLibrary::appendResolved(std::string_view name, std::string& out, std::vector<std::string_view>& included,
                                   int depth) const {
    if (depth > 16) throw Error(std::string(name), std::nullopt, "#include nesting deeper than 16 (a cycle?)");
    if (std::find(included.begin(), included.end(), name) != included.end()) return;
    included.push_back(name);
    const std::string_view text = raw(name);
    std::size_t lineNumber = 0;
    std::size_t start = 0;
    while (start < text.size()) {
        std::size_t end = text.find('\n', start);
        if (end == std::string_view::npos) end = text.size();
        const std::string_view line = text.substr(start, end - start);
        ++lineNumber;
        const std::size_t first = line.find_first_not_of(" \t");
        if (first != std::string_view::npos && line.substr(first).starts_with("#include")) {
            const std::size_t open = line.find('"');
            const std::size_t close = line.rfind('"');
            if (open == std::string_view::npos || close <= open)
                throw Error(std::string(name), std::nullopt,
                            "line " + std::to_string(lineNumber) + ": malformed #include (expected #include \"file\")");
            appendResolved(line.substr(open + 1, close - open - 1), out, included, depth + 1);
            out += "#line " + std::to_string(lineNumber + 1) + "\n";
        } else {
            out.append(line);
            out += '\n';
        }
        start = end + 1;
    }
}

std::string ShaderLibrary::preprocess(std::string_view name, std::span<const std::string> defines) const {
    std::string resolved;
    std::vector<std::string_view> included;
    appendResolved(name, resolved, included, 0);

    if (!resolved.starts_with("#version"))
        throw Error(std::string(name), std::nullopt, "shader must start with a #version line");
    const std::size_t versionEnd = resolved.find('\n') + 1;
    std::string header;
    for (const std::string& define : defines) header += "#define " + define + "\n";
    header += "#line 2\n";
    resolved.insert(versionEnd, header);
    return resolved;
}

Program ShaderLibrary::buildProgram(std::initializer_list<ShaderStage> stages, std::span<const std::string> defines) const {
    std::string variant;
    for (const std::string& define : defines) variant.append(variant.empty() ? " [" : ", ").append(define);
    if (!variant.empty()) variant += "]";

    std::vector<Shader> shaders;
    shaders.reserve(stages.size());
    std::string programName;
    for (const ShaderStage& stage : stages) {
        shaders.push_back(Shader::compile(stage.stage, preprocess(stage.name, defines), std::string(stage.name) + variant));
        programName.append(programName.empty() ? "" : "+").append(stage.name);
    }
    return Program::link(shaders, programName + variant);
}

} // namespace lightskin::gl
