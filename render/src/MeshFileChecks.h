#pragma once
// The checks every assimp import of a mesh file goes through first (MeshLoader.cpp): they turn the files that
// crash or hang assimp 5.2.5 (fuzz/MeshFuzz.cpp's findings) into lightskin::Error naming the file.

#include <assimp/Importer.hpp>

#include <filesystem>

namespace lightskin::render {

/// Throws lightskin::Error naming `path` when it does not exist, its format is not supported, or a format check
/// fails (PLY header, glTF buffers, OBJ material libraries, a reader that does not recognise the content). Also
/// routes assimp's log to lightskin's (once per process).
void checkBeforeImport(const std::filesystem::path& path, const Assimp::Importer& importer);

} // namespace lightskin::render
