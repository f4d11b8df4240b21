#include "TestPaths.h"

#include <lightskin/core/Error.h>
#include <lightskin/render/MeshLoader.h>

#include <glm/geometric.hpp>
#include <glm/vec3.hpp>
#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include <array>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <string_view>
#include <utility>
#include <vector>

using lightskin::Error;
using lightskin::TriangleMesh;
using lightskin::render::loadModel;
using lightskin::test::dataPath;

namespace {

std::string errorOf(const std::filesystem::path& path) {
    try {
        loadModel(path);
    } catch (const Error& error) {
        return error.what();
    }
    return "(no error)";
}

void expectUnitNormals(const TriangleMesh& mesh) {
    for (const glm::vec3& n : mesh.normals) ASSERT_NEAR(glm::length(n), 1.0f, 1e-4f);
}

} // namespace

TEST(MeshLoader, StanfordBunnyPlyHasItsPublishedCountsAndGetsNormals) {
    const auto model = loadModel(dataPath("meshes/bun_zipper_res4.ply"));
    ASSERT_EQ(model.parts.size(), 1u);
    // The header says 946 faces; the file also holds two "comment" lines inside the face list
    // (lines 526 and 613, the triangles zipper removed), which assimp counts among the 946 and
    // skips, so 944 triangles arrive. The PLY has no normals, so they are generated.
    // Of those, 39 repeat the corners of another triangle (30 corner sets listed 2-4 times, most copies
    // wound the other way; counted from the file with a script), and are dropped before the normals are made.
    EXPECT_EQ(model.report.droppedDuplicateTriangles, 39u);
    EXPECT_EQ(model.triangleCount() + model.report.droppedDegenerateTriangles + model.report.droppedDuplicateTriangles,
              944u);
    // Normals are smooth within the 60 degree crease angle, per corner (each corner averages the faces around
    // its position within 60 degrees of its own face): counted from the file with a script (numpy, the 907
    // distinct triangles): 452 used vertices, 177 of them with adjacent faces more than 60 degrees apart, and
    // 913 distinct (vertex, face set within 60 degrees of a corner's face) pairs, so 913 vertices. (Were a shared
    // vertex to keep one face's normal, there would be 452.)
    EXPECT_EQ(model.vertexCount(), 913u);
    // Each corner's normal is a mean of face normals within 60 degrees of its own face's, so it lies within 60
    // degrees of that face's geometric normal (cos 60 = 0.5, less 1e-4 for float rounding).
    {
        const TriangleMesh& mesh = model.parts[0].mesh;
        std::size_t outside = 0;
        double sumCos = 0.0;
        for (std::size_t t = 0; t < mesh.indices.size(); t += 3) {
            const glm::vec3 a = mesh.positions[mesh.indices[t]], b = mesh.positions[mesh.indices[t + 1]],
                            c = mesh.positions[mesh.indices[t + 2]];
            const glm::vec3 face = glm::normalize(glm::cross(b - a, c - a));
            for (std::size_t k = 0; k < 3; ++k) {
                const float cosine = glm::dot(mesh.normals[mesh.indices[t + k]], face);
                sumCos += double(cosine);
                if (cosine < 0.5f - 1e-4f) ++outside;
            }
        }
        EXPECT_EQ(outside, 0u) << "mean cos " << sumCos / double(mesh.indices.size());
        std::printf("bunny: mean cos(corner normal, face normal) %.4f\n", sumCos / double(mesh.indices.size()));
    }
    EXPECT_EQ(model.report.partsWithGeneratedNormals, 1u);
    expectUnitNormals(model.parts[0].mesh);
    // y range of the 453 vertices, read from the file with a script: 0.0336204 .. 0.181897.
    float minY = 1e9f, maxY = -1e9f;
    for (const glm::vec3& p : model.parts[0].mesh.positions) {
        minY = std::min(minY, p.y);
        maxY = std::max(maxY, p.y);
    }
    EXPECT_FLOAT_EQ(minY, 0.0336204f);
    EXPECT_FLOAT_EQ(maxY, 0.181897f);
}

namespace {

/// A roof of 8 triangles over a 3x3 grid (x, y in {0, 1, 2}), its ridge along x = 1 raised so that the
/// two planes meet at a 13 degree crease (the bunny's), all wound counter-clockwise seen
/// from +z; plus one copy of a ridge triangle wound the other way, listed first or last. ASCII PLY
/// with shared vertices (as bun_zipper_res4.ply): assimp then writes each face's normal into the
/// shared vertex slots, so a reversed copy listed last decides its corners' normals.
std::string roofPly(bool reversedCopyFirst) {
    const double ridge = std::tan(6.5 * 3.14159265358979 / 180.0); // each side 6.5 degrees from level
    std::ostringstream ply;
    ply << "ply\nformat ascii 1.0\nelement vertex 9\nproperty float x\nproperty float y\nproperty float z\n"
           "element face 9\nproperty list uchar int vertex_indices\nend_header\n";
    for (int y = 0; y < 3; ++y)
        for (int x = 0; x < 3; ++x) ply << x << ' ' << y << ' ' << (x == 1 ? ridge : 0.0) << '\n';
    const std::string reversed = "3 4 1 0\n"; // the copy of "3 0 1 4" wound the other way
    if (reversedCopyFirst) ply << reversed;
    for (int y = 0; y < 2; ++y)
        for (int x = 0; x < 2; ++x) {
            const int a = 3 * y + x;
            ply << "3 " << a << ' ' << a + 1 << ' ' << a + 4 << "\n3 " << a << ' ' << a + 4 << ' ' << a + 3 << '\n';
        }
    if (!reversedCopyFirst) ply << reversed;
    return ply.str();
}

} // namespace

// The brute force's black pixel on the PCL TIFF: a triangle listed twice, once wound the
// other way, turned its corners' generated normals by up to ~170 degrees. The reference is the roof's
// own geometry: generated normals average the normals of adjacent faces (within the crease angle), so each
// lies within the 13 degree crease of every outward face around it, and every kept face faces +z.
TEST(MeshLoader, ATriangleListedTwiceWithReversedWindingIsDroppedBeforeTheNormalsAreMade) {
    const auto scratch = lightskin::test::scratchDir("mesh_duplicate_triangles");
    for (const bool first : {false, true}) {
        SCOPED_TRACE(first ? "reversed copy listed first" : "reversed copy listed last");
        const auto path = scratch / (first ? "roof_first.ply" : "roof_last.ply");
        std::ofstream(path) << roofPly(first);
        const auto model = loadModel(path);
        ASSERT_EQ(model.parts.size(), 1u);
        const TriangleMesh& mesh = model.parts[0].mesh;
        EXPECT_EQ(mesh.triangleCount(), 8u);
        EXPECT_EQ(model.report.droppedDuplicateTriangles, 1u);
        const float creaseCos = std::cos(13.0f * 3.14159265f / 180.0f) - 1e-5f; // float rounding of the normals
        for (std::size_t t = 0; t < mesh.indices.size(); t += 3) {
            const glm::vec3 a = mesh.positions[mesh.indices[t]], b = mesh.positions[mesh.indices[t + 1]],
                            c = mesh.positions[mesh.indices[t + 2]];
            const glm::vec3 face = glm::normalize(glm::cross(b - a, c - a));
            EXPECT_GT(face.z, 0.99f) << "triangle " << t / 3 << " kept the reversed winding";
            for (int k = 0; k < 3; ++k)
                EXPECT_GE(glm::dot(mesh.normals[mesh.indices[t + std::size_t(k)]], face), creaseCos)
                    << "triangle " << t / 3 << " corner " << k;
        }
    }
}

TEST(MeshLoader, CornellBoxObjMaterialsAndAmbientEmission) {
    const auto model = loadModel(dataPath("meshes/cornell_box.obj"));
    // Node transforms are baked in and meshes of one material merged: white (floor, ceiling, back
    // wall, two blocks), red, green, light. The blue front wall has its face commented out.
    ASSERT_EQ(model.parts.size(), 4u);
    EXPECT_EQ(model.triangleCount(), 36u); // the 18 "f" lines are quads, 2 triangles each
    bool sawRed = false, sawGreen = false, sawLight = false;
    for (const auto& part : model.parts) {
        const glm::vec3 kd = part.material.diffuseAlbedo;
        if (part.materialName == "red") {
            sawRed = true;
            EXPECT_EQ(kd, glm::vec3(1, 0, 0));
        }
        if (part.materialName == "green") {
            sawGreen = true;
            EXPECT_EQ(kd, glm::vec3(0, 1, 0));
        }
        if (part.materialName == "light") {
            sawLight = true;
            EXPECT_EQ(part.emission, glm::vec3(20.0f)); // stored as Ka 20 20 20
        } else {
            EXPECT_EQ(part.emission, glm::vec3(0.0f));
        }
        EXPECT_FALSE(part.material.hasSpecular());
        expectUnitNormals(part.mesh);
    }
    EXPECT_TRUE(sawRed && sawGreen && sawLight);
}

TEST(MeshLoader, CubeWithoutNormalsKeepsFlatFacesThanksToTheCreaseAngle) {
    const auto model = loadModel(dataPath("meshes/box_no_normals.obj"));
    ASSERT_EQ(model.parts.size(), 1u);
    const TriangleMesh& mesh = model.parts[0].mesh;
    EXPECT_EQ(mesh.triangleCount(), 12u);
    EXPECT_EQ(mesh.vertexCount(), 24u); // 4 per face: corners are split at the 90 degree creases
    for (std::size_t t = 0; t < mesh.indices.size(); t += 3) {
        const glm::vec3 a = mesh.positions[mesh.indices[t]], b = mesh.positions[mesh.indices[t + 1]],
                        c = mesh.positions[mesh.indices[t + 2]];
        const glm::vec3 faceNormal = glm::normalize(glm::cross(b - a, c - a));
        // Outward (counter-clockwise) faces of a cube centred at the origin point away from it.
        EXPECT_GT(glm::dot(faceNormal, (a + b + c) / 3.0f), 0.0f);
        for (int k = 0; k < 3; ++k)
            EXPECT_NEAR(glm::dot(mesh.normals[mesh.indices[t + std::size_t(k)]], faceNormal), 1.0f, 1e-5f);
    }
}

TEST(MeshLoader, DegenerateTrianglesAreDroppedAndCounted) {
    const auto model = loadModel(dataPath("meshes/degenerate_no_normals.obj"));
    ASSERT_EQ(model.parts.size(), 1u);
    EXPECT_EQ(model.parts[0].mesh.triangleCount(), 2u);
    EXPECT_EQ(model.report.droppedDegenerateTriangles, 2u);
    EXPECT_EQ(model.parts[0].mesh.vertexCount(), 4u); // v5 was used only by a dropped triangle
    for (const glm::vec3& n : model.parts[0].mesh.normals) EXPECT_NEAR(n.z, 1.0f, 1e-5f);
}

TEST(MeshLoader, GltfTriangleWithNodeTransformAndBaseColour) {
    const auto model = loadModel(dataPath("meshes/triangle.gltf"));
    ASSERT_EQ(model.parts.size(), 1u);
    const TriangleMesh& mesh = model.parts[0].mesh;
    ASSERT_EQ(mesh.triangleCount(), 1u);
    for (const glm::vec3& p : mesh.positions) EXPECT_FLOAT_EQ(p.z, 2.0f); // node translation baked in
    for (const glm::vec3& n : mesh.normals) EXPECT_NEAR(n.z, 1.0f, 1e-6f);
    EXPECT_NEAR(model.parts[0].material.diffuseAlbedo.r, 0.9f, 1e-6f);
    EXPECT_NEAR(model.parts[0].material.diffuseAlbedo.g, 0.5f, 1e-6f);
    EXPECT_FALSE(model.parts[0].material.hasSpecular());
}

TEST(MeshLoader, BadFilesGiveErrorsNamingTheFileAndCause) {
    const auto dir = dataPath("meshes");
    const std::string nan = errorOf(dir / "nan_vertex.obj");
    EXPECT_NE(nan.find("nan_vertex.obj"), std::string::npos) << nan;
    EXPECT_NE(nan.find("non-finite position"), std::string::npos) << nan;

    const std::string range = errorOf(dir / "index_out_of_range.obj");
    EXPECT_NE(range.find("index_out_of_range.obj"), std::string::npos) << range;
    EXPECT_EQ(range.find("(no error)"), std::string::npos) << range;

    const std::string points = errorOf(dir / "points_only.obj");
    EXPECT_NE(points.find("points_only.obj"), std::string::npos) << points;
    EXPECT_EQ(points.find("(no error)"), std::string::npos) << points;

    const std::string missing = errorOf(dir / "does_not_exist.obj");
    EXPECT_NE(missing.find("does not exist"), std::string::npos) << missing;

    const std::string format = errorOf(dir / "not_a_mesh.xyz");
    EXPECT_NE(format.find("unsupported mesh format"), std::string::npos) << format;

    const std::string truncated = errorOf(dir / "truncated.ply");
    EXPECT_NE(truncated.find("truncated.ply"), std::string::npos) << truncated;
    EXPECT_NE(truncated.find("no end_header"), std::string::npos) << truncated;

    const std::string truncatedBinary = errorOf(dir / "truncated_binary.ply");
    EXPECT_NE(truncatedBinary.find("binary PLY is truncated"), std::string::npos) << truncatedBinary;

    // Fuzz finding: an ASCII PLY claiming 2^31 - 1 faces made assimp reserve 32 GB before reading any.
    const std::string overflow = errorOf(dir / "ascii_face_count_overflow.ply");
    EXPECT_NE(overflow.find("ascii_face_count_overflow.ply"), std::string::npos) << overflow;
    EXPECT_NE(overflow.find("ASCII PLY is truncated or its element counts are wrong"), std::string::npos) << overflow;
    EXPECT_NE(overflow.find("need at least 4294967"), std::string::npos) << overflow; // 2 bytes x (2^31 - 1) faces
    // Counts below the file size but more than its body holds (300 vertices, 3 given): 2 bytes per value.
    // Fuzz finding 2b: a face's list count far beyond its uchar type made assimp allocate 32 GB.
    const std::string listCount = errorOf(dir / "ascii_list_count_overflow.ply");
    EXPECT_NE(listCount.find("element 'face' 0: list count '99999999999993' is not a whole number within its count "
                             "type (0..255)"),
              std::string::npos)
        << listCount;
    // Fuzz finding 12: the face line missing (the body's size still passed); assimp read the last vertex
    // line again as the face, took its "99999999999993" as the list count and allocated 2.2 GB.
    const auto bodyScratch = lightskin::test::scratchDir("mesh_missing_face");
    std::ofstream(bodyScratch / "missing_face.ply")
        << "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n"
           "element face 1\nproperty list uchar int vertex_indices\nend_header\n"
           "0 0 0\n1 0 0\n0 1 0\n99999999999993 232 243 227\n";
    const std::string missingFace = errorOf(bodyScratch / "missing_face.ply");
    EXPECT_NE(missingFace.find("missing_face.ply"), std::string::npos) << missingFace;
    EXPECT_NE(missingFace.find("ASCII PLY: the body ends before element 'face' 0 (the header counts 1"),
              std::string::npos)
        << missingFace;
    // assimp reads the leading digits of an element name as its count (53 GB): refused first.
    std::ofstream(bodyScratch / "element_name_digits.ply")
        << "ply\nformat ascii 1.0\nelement 33333333333333333333vertex 3\nproperty float x\nproperty float y\n"
           "property float z\nend_header\n0 0 0\n1 0 0\n0 1 0\n";
    const std::string nameDigits = errorOf(bodyScratch / "element_name_digits.ply");
    EXPECT_NE(nameDigits.find("element_name_digits.ply"), std::string::npos) << nameDigits;
    EXPECT_NE(nameDigits.find("element name '33333333333333333333vertex' does not start with a letter"),
              std::string::npos)
        << nameDigits;
    // Fuzz finding 14: "ascii\0" was binary to this check and ASCII to assimp, which took the unchecked
    // list count 9999999999 and allocated 11 GB.
    using namespace std::string_view_literals;
    std::ofstream(bodyScratch / "format_nul.ply", std::ios::binary)
        << std::string_view("ply\nformat ascii\0 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                            "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n"
                            "0 0 0\n1 0 0\n0 1 0\n9999999999 0 1 2\n"sv);
    const std::string formatNul = errorOf(bodyScratch / "format_nul.ply");
    EXPECT_NE(formatNul.find("format_nul.ply"), std::string::npos) << formatNul;
    EXPECT_NE(formatNul.find("PLY header: control character in line 2"), std::string::npos) << formatNul;
    // Fuzz findings 15 and 16: a NUL inside a body line made assimp read a vertex value as a list count.
    std::ofstream(bodyScratch / "body_nul.ply", std::ios::binary)
        << std::string_view("ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\n"
                            "property list uchar int indices\nend_header\n0 0\n9\0\0\09999999999993 2 1 0\n0 0\n"sv);
    const std::string bodyNul = errorOf(bodyScratch / "body_nul.ply");
    EXPECT_NE(bodyNul.find("body_nul.ply"), std::string::npos) << bodyNul;
    EXPECT_NE(bodyNul.find("ASCII PLY: control character in the line of element 'vertex' 1"), std::string::npos)
        << bodyNul;
    // Fuzz finding 17: a list count of 232 over 3 values; assimp read the rest from the next lines.
    std::ofstream(bodyScratch / "short_list.ply")
        << "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
           "element face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n4 0 1 2\n";
    const std::string shortList = errorOf(bodyScratch / "short_list.ply");
    EXPECT_NE(shortList.find("element 'face' 0 has fewer values on its line than its properties need"),
              std::string::npos)
        << shortList;
    std::ofstream(bodyScratch / "short_vertex.ply")
        << "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
           "element face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0\n0 1 0\n3 0 1 2\n";
    const std::string shortVertex = errorOf(bodyScratch / "short_vertex.ply");
    EXPECT_NE(shortVertex.find("element 'vertex' 1 has fewer values on its line than its properties need"),
              std::string::npos)
        << shortVertex;
    std::ofstream(bodyScratch / "format_unknown.ply")
        << "ply\nformat text 1.0\nelement vertex 0\nproperty float x\nend_header\n";
    const std::string formatUnknown = errorOf(bodyScratch / "format_unknown.ply");
    EXPECT_NE(formatUnknown.find("PLY header: unknown format 'text'"), std::string::npos) << formatUnknown;
    // Fuzz finding: 2^31 - 1 faces whose property line is misspelt (so no value counted) kept
    // assimp reading for minutes: an unknown header line is refused.
    const std::string noProperties = errorOf(dir / "ascii_element_without_properties.ply");
    EXPECT_NE(noProperties.find("PLY header: unknown line 'proper"), std::string::npos) << noProperties;
    // Fuzz finding: a material property before the first newmtl crashed assimp's MTL reader (SEGV).
    const std::string mtl = errorOf(dir / "mtl_property_before_newmtl.obj");
    EXPECT_NE(mtl.find("mtl_property_before_newmtl.mtl"), std::string::npos) << mtl;
    EXPECT_NE(mtl.find("line 1: 'Kd' before the first 'newmtl'"), std::string::npos) << mtl;
    const std::string shortBody = errorOf(dir / "ascii_counts_exceed_body.ply");
    EXPECT_NE(shortBody.find("ASCII PLY is truncated or its element counts are wrong"), std::string::npos) << shortBody;
    // Fuzz finding 10: content of another format than the extension says went to the reader assimp
    // sniffed (PLY text in a .glb reached the PLY reader past checkPlyHeader, and assimp hung).
    const auto scratch = lightskin::test::scratchDir("mesh_content");
    const std::string ply = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                            "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n"
                            "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";
    for (const auto& [name, cause] :
         {std::pair<std::string, std::string>{"ply_text.glb", "reader does not recognise the content"},
          {"ply_text.gltf", "malformed glTF JSON"}}) {
        std::ofstream(scratch / name) << ply;
        const std::string wrong = errorOf(scratch / name);
        EXPECT_NE(wrong.find(name), std::string::npos) << wrong;
        EXPECT_NE(wrong.find(cause), std::string::npos) << wrong;
    }
    std::ofstream(scratch / "ply_text.ply") << ply; // the same bytes under their own extension load
    EXPECT_EQ(lightskin::render::loadModel(scratch / "ply_text.ply").triangleCount(), 1u);
    // assimp's OBJ reader recognises content by a keyword in its first 200 bytes, so that sniff must not
    // decide for an extension only one reader takes: a valid OBJ opening with a long comment loads.
    std::ofstream(scratch / "long_comment.obj") << "# " << std::string(300, 'c') << "\n"
                                                << "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
    EXPECT_EQ(lightskin::render::loadModel(scratch / "long_comment.obj").triangleCount(), 1u);
}

TEST(MeshLoader, RemoveDegenerateTrianglesOnAHandMadeMesh) {
    TriangleMesh mesh;
    mesh.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {5, 5, 5}, {2, 0, 0}};
    mesh.normals.assign(5, {0, 0, 1});
    mesh.indices = {0, 1, 2, /*repeat*/ 2, 2, 1, /*collinear*/ 0, 1, 4, 3, 3, 3};
    const auto repair = lightskin::render::removeDegenerateTriangles(mesh);
    EXPECT_EQ(repair.droppedTriangles, 3u);
    EXPECT_EQ(repair.removedVertices, 2u);
    EXPECT_EQ(mesh.indices, (std::vector<std::uint32_t>{0, 1, 2}));
    EXPECT_EQ(mesh.positions.size(), 3u);
    EXPECT_NO_THROW(mesh.validate("hand-made"));
}

// Files a mesh depends on, missing or corrupt. Each names the mesh file and the cause.
TEST(MeshLoader, MissingMaterialLibraryOrCorruptGltfBufferIsAnError) {
    const auto dir = lightskin::test::scratchDir("mesh_dependencies");
    const auto expectCause = [](const std::filesystem::path& path, const std::string& cause) {
        try {
            loadModel(path);
            ADD_FAILURE() << path << ": no error, expected '" << cause << "'";
        } catch (const Error& error) {
            EXPECT_EQ(error.source(), path.string());
            EXPECT_NE(error.cause().find(cause), std::string::npos) << error.what();
        }
    };
    // An OBJ whose mtllib is absent (assimp alone would use a default grey material and log a line).
    std::ofstream(dir / "no_mtl.obj") << "mtllib absent.mtl\nusemtl red\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
    expectCause(dir / "no_mtl.obj", "material library 'absent.mtl' (mtllib) does not exist");
    // Fuzz finding 11: NUL bytes in a comment line hid what followed them from our check, and assimp's
    // MTL reader (which ends lines at NULs) crashed on it.
    std::ofstream(dir / "absent.mtl", std::ios::binary) << std::string("# comment\0 Kd 1 1 1\nnewmtl red\n", 31);
    try {
        loadModel(dir / "no_mtl.obj");
        ADD_FAILURE() << "a material library with NUL bytes loaded";
    } catch (const Error& error) { // named like the other library errors: the library file and its line
        EXPECT_EQ(error.source(), (dir / "absent.mtl").string());
        EXPECT_NE(error.cause().find("line 1: NUL byte in a text file"), std::string::npos) << error.what();
    }
    // The same OBJ with the library present loads, with the library's colour.
    std::ofstream(dir / "absent.mtl") << "newmtl red\nKd 0.3 0.6 0.1\n";
    const auto withMtl = loadModel(dir / "no_mtl.obj");
    ASSERT_EQ(withMtl.parts.size(), 1u);
    // Not the default albedo (0.8 grey): the library was read.
    EXPECT_NEAR(withMtl.parts[0].material.diffuseAlbedo.r, 0.3f, 1e-6f);
    EXPECT_NEAR(withMtl.parts[0].material.diffuseAlbedo.g, 0.6f, 1e-6f);

    // A glTF triangle whose positions live in tri.bin (3 float vec3 = 36 bytes).
    const std::string gltf =
        R"({"asset":{"version":"2.0"},"scene":0,"scenes":[{"nodes":[0]}],"nodes":[{"mesh":0}],)"
        R"("meshes":[{"primitives":[{"attributes":{"POSITION":0}}]}],)"
        R"("buffers":[{"uri":"tri.bin","byteLength":36}],"bufferViews":[{"buffer":0,"byteLength":36}],)"
        R"("accessors":[{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[1,1,0]}]})";
    std::ofstream(dir / "tri.gltf") << gltf;
    expectCause(dir / "tri.gltf", "buffers[0]: buffer file 'tri.bin' does not exist");
    const float positions[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
    std::ofstream(dir / "tri.bin", std::ios::binary).write(reinterpret_cast<const char*>(positions), 28);
    expectCause(dir / "tri.gltf", "buffers[0]: buffer file 'tri.bin' is 28 bytes, shorter than its byteLength 36");
    std::ofstream(dir / "tri.bin", std::ios::binary | std::ios::trunc)
        .write(reinterpret_cast<const char*>(positions), sizeof positions);
    const auto triangle = loadModel(dir / "tri.gltf");
    EXPECT_EQ(triangle.triangleCount(), 1u);
    std::ofstream(dir / "tri.gltf", std::ios::trunc) << gltf.substr(0, gltf.size() / 2);
    expectCause(dir / "tri.gltf", "malformed glTF JSON");
}

// The small-scale maps of recordings/scenes/meshes/make_ao_tile.py's tiles. assimp 5.2.5 hands
// glTF's occlusionTexture over as a lightmap and flips glTF's v (uv (0, 0) = the image's top-left) to v = 1 - v.
TEST(MeshLoader, GltfOcclusionAndNormalMapsKeepTheirFilesStrengthAndScale) {
    const auto meshes = lightskin::test::sourceDir() / "recordings/scenes/meshes";
    const auto model = loadModel(meshes / "ao_tile.gltf");
    ASSERT_EQ(model.parts.size(), 1u);
    const lightskin::Material& material = model.parts[0].material;
    EXPECT_EQ(model.parts[0].materialName, "ao_checker");
    EXPECT_EQ(material.occlusionTexture, (meshes / "ao_tile_occlusion.png").lexically_normal().string());
    EXPECT_EQ(material.occlusionStrength, 0.75f);
    EXPECT_EQ(material.normalTexture, (meshes / "ao_tile_normal.png").lexically_normal().string());
    EXPECT_EQ(material.normalScale, 1.0f);
    const TriangleMesh& mesh = model.parts[0].mesh;
    ASSERT_EQ(mesh.texcoords.size(), mesh.positions.size());
    for (std::size_t v = 0; v < mesh.positions.size(); ++v) { // the file's uv = (x, 1 - y), flipped once by assimp
        EXPECT_NEAR(mesh.texcoords[v].x, mesh.positions[v].x, 1e-6f);
        EXPECT_NEAR(mesh.texcoords[v].y, mesh.positions[v].y, 1e-6f);
    }
    // The occlusion file holds what the script documents: R = 64 in the top-left 2 x 2 cell, a checker of 255
    // and 128 elsewhere; G = 0, B = 255 (so a reader of another channel is caught downstream).
    const cv::Mat bgr = cv::imread(material.occlusionTexture, cv::IMREAD_COLOR);
    ASSERT_EQ(bgr.size(), cv::Size(8, 8));
    for (int row = 0; row < 8; ++row)
        for (int column = 0; column < 8; ++column) {
            const cv::Vec3b texel = bgr.at<cv::Vec3b>(row, column);
            const int expected = row < 2 && column < 2 ? 64 : (row / 2 + column / 2) % 2 == 0 ? 255 : 128;
            EXPECT_EQ(int(texel[2]), expected) << row << ", " << column;
            EXPECT_EQ(int(texel[1]), 0);
            EXPECT_EQ(int(texel[0]), 255);
        }

    const auto normalOnly = loadModel(meshes / "normal_tile.gltf");
    ASSERT_EQ(normalOnly.parts.size(), 1u);
    EXPECT_TRUE(normalOnly.parts[0].material.occlusionTexture.empty());
    EXPECT_EQ(normalOnly.parts[0].material.normalTexture, material.normalTexture);
    EXPECT_EQ(normalOnly.parts[0].material.normalScale, 0.5f);
    // Without maps the defaults stay (strength and scale 1, no files).
    const auto plain = loadModel(dataPath("meshes/triangle.gltf"));
    EXPECT_TRUE(plain.parts[0].material.occlusionTexture.empty());
    EXPECT_TRUE(plain.parts[0].material.normalTexture.empty());
    EXPECT_EQ(plain.parts[0].material.occlusionStrength, 1.0f);
}

TEST(MeshLoader, ObjNormalMapKeepsItsBumpMultiplierAndMissingMapsAreErrorsNamingFileAndMaterial) {
    const auto dir = lightskin::test::scratchDir("mesh_small_scale_maps");
    std::ofstream(dir / "tile.obj") << "mtllib tile.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\n"
                                       "usemtl bumpy\nf 1/1 2/2 3/3\n";
    std::ofstream(dir / "tile.mtl") << "newmtl bumpy\nKd 0.5 0.5 0.5\nnorm -bm 0.25 normal.png\nmap_Bump height.png\n";
    const auto expectCause = [](const std::filesystem::path& path, const std::string& cause) {
        try {
            loadModel(path);
            ADD_FAILURE() << path << ": no error, expected '" << cause << "'";
        } catch (const Error& error) {
            EXPECT_EQ(error.source(), path.string());
            EXPECT_NE(error.cause().find(cause), std::string::npos) << error.what();
        }
    };
    expectCause(dir / "tile.obj",
                "material 'bumpy': normal texture '" + (dir / "normal.png").string() + "' does not exist");
    std::filesystem::copy_file(lightskin::test::sourceDir() / "recordings/scenes/meshes/ao_tile_normal.png",
                               dir / "normal.png");
    // The height map (map_Bump) is not used by the small scale (logged), so its absence is no error.
    const auto model = loadModel(dir / "tile.obj");
    ASSERT_EQ(model.parts.size(), 1u);
    EXPECT_EQ(model.parts[0].material.normalTexture, (dir / "normal.png").string());
    EXPECT_EQ(model.parts[0].material.normalScale, 0.25f);
    EXPECT_TRUE(model.parts[0].material.occlusionTexture.empty());

    // A glTF whose occlusion texture is missing: the tile with its image renamed.
    std::string gltf =
        lightskin::test::readText(lightskin::test::sourceDir() / "recordings/scenes/meshes/ao_tile.gltf");
    const std::size_t at = gltf.find("ao_tile_occlusion.png");
    ASSERT_NE(at, std::string::npos);
    gltf.replace(at, std::string("ao_tile_occlusion.png").size(), "gone.png");
    std::ofstream(dir / "ao_tile.gltf") << gltf;
    std::filesystem::copy_file(lightskin::test::sourceDir() / "recordings/scenes/meshes/ao_tile.bin",
                               dir / "ao_tile.bin");
    std::filesystem::copy_file(dir / "normal.png", dir / "ao_tile_normal.png");
    expectCause(dir / "ao_tile.gltf",
                "material 'ao_checker': occlusion texture '" + (dir / "gone.png").string() + "' does not exist");
}

// Smooth normals for meshes whose faces share vertices. assimp 5.2.5's GenSmoothNormals
// averages over distinct vertices at a position only, so on an indexed PLY a shared vertex would keep the normal of
// its last face; the loader gives every corner its own vertex first (render/src/MeshLoader.cpp).
namespace {

constexpr double kPi = 3.14159265358979323846;

/// A unit UV sphere: poles at +-z, `rings` latitude bands, `sectors` (even) longitudes; quads between rings
/// split along alternating diagonals (a checkerboard), so the triangles around every ring vertex are mirror
/// images of each other across the vertex's meridian plane; pole fans. Wound outward. Shared vertices.
struct Sphere {
    std::vector<glm::dvec3> vertices;
    std::vector<std::array<int, 3>> triangles;
};
Sphere uvSphere(int rings, int sectors) {
    Sphere s;
    s.vertices.push_back({0.0, 0.0, 1.0});
    for (int i = 1; i < rings; ++i) {
        const double lat = kPi / 2 - kPi * i / rings;
        for (int j = 0; j < sectors; ++j) {
            const double lon = 2 * kPi * j / sectors;
            s.vertices.push_back({std::cos(lat) * std::cos(lon), std::cos(lat) * std::sin(lon), std::sin(lat)});
        }
    }
    s.vertices.push_back({0.0, 0.0, -1.0});
    const int south = int(s.vertices.size()) - 1;
    const auto at = [&](int ring, int j) { return 1 + (ring - 1) * sectors + (j % sectors); }; // ring 1..rings-1
    for (int j = 0; j < sectors; ++j) {
        s.triangles.push_back({0, at(1, j), at(1, j + 1)});
        s.triangles.push_back({south, at(rings - 1, j + 1), at(rings - 1, j)});
    }
    for (int i = 1; i + 1 < rings; ++i)
        for (int j = 0; j < sectors; ++j) {
            const int a = at(i, j), b = at(i, j + 1), c = at(i + 1, j + 1), d = at(i + 1, j); // a b above, d c below
            if ((i + j) % 2 == 0) {
                s.triangles.push_back({a, d, c});
                s.triangles.push_back({a, c, b});
            } else {
                s.triangles.push_back({a, d, b});
                s.triangles.push_back({b, d, c});
            }
        }
    return s;
}

std::string spherePly(const Sphere& s) {
    std::ostringstream ply;
    ply.precision(9);
    ply << "ply\nformat ascii 1.0\nelement vertex " << s.vertices.size()
        << "\nproperty float x\nproperty float y\nproperty float z\nelement face " << s.triangles.size()
        << "\nproperty list uchar int vertex_indices\nend_header\n";
    for (const glm::dvec3& v : s.vertices) ply << v.x << ' ' << v.y << ' ' << v.z << '\n';
    for (const auto& t : s.triangles) ply << "3 " << t[0] << ' ' << t[1] << ' ' << t[2] << '\n';
    return ply.str();
}

std::string sphereObj(const Sphere& s) {
    std::ostringstream obj;
    obj.precision(9);
    for (const glm::dvec3& v : s.vertices) obj << "v " << v.x << ' ' << v.y << ' ' << v.z << '\n';
    for (const auto& t : s.triangles) obj << "f " << t[0] + 1 << ' ' << t[1] + 1 << ' ' << t[2] + 1 << '\n';
    return obj.str();
}

} // namespace

// Reference: the sphere's exact normal, the radial direction. Derivation of the bounds (geometry only):
// (1) every face is inscribed in the unit sphere, so its normal points at its circumcentre, which lies
// between the face's rings (latitude) and at the mid-longitude of its quad (the quads are isosceles
// trapezoids, symmetric about their mid-meridian). So any average of the faces around a vertex has a
// latitude within one ring spacing (pi / rings) of the vertex's: angle to the radial <= pi / rings
// (+1e-4 rad for float positions and normals). (2) The triangles around a ring vertex are mirror images
// across its meridian plane (the checkerboard diagonals; pole fans are symmetric too), and the crease
// angle (60 degrees) keeps all of them (adjacent normals differ by <= 2 x 22.5 degrees here), so a smooth
// normal lies in that plane: its component along the east direction is 0 up to float rounding (1e-5).
// One face's normal (the old behaviour: the last face of a shared vertex) leaves the plane by
// cos(lat) sin(pi / sectors / 2) ~ 0.07-0.19 on these rings, far above 1e-5.
TEST(MeshLoader, IndexedPlySphereGetsSmoothRadialNormals) {
    constexpr int rings = 8, sectors = 16;
    const Sphere sphere = uvSphere(rings, sectors);
    const auto path = lightskin::test::scratchDir("mesh_smooth_normals") / "sphere.ply";
    std::ofstream(path) << spherePly(sphere);
    const auto model = loadModel(path);
    ASSERT_EQ(model.parts.size(), 1u);
    const TriangleMesh& mesh = model.parts[0].mesh;
    EXPECT_EQ(mesh.triangleCount(), sphere.triangles.size());
    // One normal per position: the re-joined corners agree (no crease on a sphere this fine).
    EXPECT_EQ(mesh.vertexCount(), sphere.vertices.size());
    const double latitudeBound = kPi / rings + 1e-4;
    for (std::size_t v = 0; v < mesh.vertexCount(); ++v) {
        const glm::dvec3 p = glm::normalize(glm::dvec3(mesh.positions[v]));
        const glm::dvec3 n(mesh.normals[v]);
        EXPECT_GE(glm::dot(n, p), std::cos(latitudeBound))
            << "vertex " << v << " at " << p.x << ' ' << p.y << ' ' << p.z;
        const glm::dvec3 east = glm::dvec3(-p.y, p.x, 0.0);
        if (glm::length(east) > 1e-6) {
            EXPECT_NEAR(glm::dot(n, glm::normalize(east)), 0.0, 1e-5)
                << "vertex " << v << ": not in its meridian plane";
        } else {
            EXPECT_NEAR(std::abs(n.z), 1.0, 1e-5) << "pole vertex " << v;
        }
    }
}

// The same mesh as OBJ (assimp's OBJ reader gives every corner its own vertex) and as indexed PLY must give the
// same normal at every position (float rounding of two summation orders: 1e-5).
TEST(MeshLoader, ObjAndIndexedPlyOfOneMeshGiveTheSameNormals) {
    const Sphere sphere = uvSphere(6, 10);
    const auto scratch = lightskin::test::scratchDir("mesh_smooth_normals_obj_ply");
    std::ofstream(scratch / "sphere.ply") << spherePly(sphere);
    std::ofstream(scratch / "sphere.obj") << sphereObj(sphere);
    const auto ply = loadModel(scratch / "sphere.ply"), obj = loadModel(scratch / "sphere.obj");
    ASSERT_EQ(ply.parts.size(), 1u);
    ASSERT_EQ(obj.parts.size(), 1u);
    const TriangleMesh &a = ply.parts[0].mesh, &b = obj.parts[0].mesh;
    ASSERT_EQ(a.vertexCount(), b.vertexCount());
    std::size_t matched = 0;
    for (std::size_t i = 0; i < a.vertexCount(); ++i)
        for (std::size_t j = 0; j < b.vertexCount(); ++j)
            if (glm::length(a.positions[i] - b.positions[j]) < 1e-6f) {
                ++matched;
                EXPECT_LT(glm::length(a.normals[i] - b.normals[j]), 1e-5f) << "position of PLY vertex " << i;
            }
    EXPECT_EQ(matched, a.vertexCount());
}

namespace {

/// A cube [-1, 1]^3 as indexed PLY: 8 shared vertices, 12 outward triangles.
std::string cubePly() {
    std::ostringstream ply;
    ply << "ply\nformat ascii 1.0\nelement vertex 8\nproperty float x\nproperty float y\nproperty float z\n"
           "element face 12\nproperty list uchar int vertex_indices\nend_header\n";
    for (int v = 0; v < 8; ++v)
        ply << ((v & 1) ? 1 : -1) << ' ' << ((v & 2) ? 1 : -1) << ' ' << ((v & 4) ? 1 : -1) << '\n';
    // Each face as a quad a b c d counter-clockwise seen from outside, split into (a b c) and (a c d).
    const int quads[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4}, {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
    for (const auto& q : quads)
        ply << "3 " << q[0] << ' ' << q[1] << ' ' << q[2] << "\n3 " << q[0] << ' ' << q[2] << ' ' << q[3] << '\n';
    return ply.str();
}

} // namespace

// Crease rule on shared vertices. Sharp: the cube's edges are 90 degrees, above the 60 degree crease angle, so
// every corner keeps its own face's normal exactly (the face normal, 1e-5 for float), and each cube corner splits
// into 3 vertices (24). Gentle: the roof's 13 degree ridge is smoothed: a ridge vertex averages faces of both
// planes (normals (-+s, 0, c), s = sin 6.5 degrees), with at most 2:1 weight for one side (counted from roofPly's
// triangulation: 1 vs 2 triangles at the ridge's ends, 3 vs 3 at its centre), so |n.x| <= s / 3 / |n| < s / 2,
// and the centre's star is mirror symmetric about x = 1, so its n.x = 0 (1e-5). One face's normal has |n.x| = s.
TEST(MeshLoader, SharpEdgesKeepFaceNormalsAndGentleEdgesAreSmoothedOnSharedVertices) {
    const auto scratch = lightskin::test::scratchDir("mesh_smooth_normals_crease");
    std::ofstream(scratch / "cube.ply") << cubePly();
    const auto cube = loadModel(scratch / "cube.ply");
    ASSERT_EQ(cube.parts.size(), 1u);
    const TriangleMesh& box = cube.parts[0].mesh;
    EXPECT_EQ(box.triangleCount(), 12u);
    EXPECT_EQ(box.vertexCount(), 24u);
    for (std::size_t t = 0; t < box.indices.size(); t += 3) {
        const glm::vec3 a = box.positions[box.indices[t]], b = box.positions[box.indices[t + 1]],
                        c = box.positions[box.indices[t + 2]];
        const glm::vec3 face = glm::normalize(glm::cross(b - a, c - a));
        EXPECT_GT(glm::dot(face, (a + b + c) / 3.0f), 0.0f) << "triangle " << t / 3 << " faces inward";
        for (int k = 0; k < 3; ++k)
            EXPECT_NEAR(glm::dot(box.normals[box.indices[t + std::size_t(k)]], face), 1.0f, 1e-5f)
                << "triangle " << t / 3 << " corner " << k;
    }

    std::ofstream(scratch / "roof.ply") << roofPly(false);
    const auto roof = loadModel(scratch / "roof.ply");
    ASSERT_EQ(roof.parts.size(), 1u);
    const TriangleMesh& mesh = roof.parts[0].mesh;
    EXPECT_EQ(mesh.vertexCount(), 9u); // no crease split at 13 degrees
    const float s = float(std::sin(6.5 * kPi / 180.0));
    int ridge = 0;
    for (std::size_t v = 0; v < mesh.vertexCount(); ++v) {
        if (std::abs(mesh.positions[v].x - 1.0f) > 1e-6f) continue;
        ++ridge;
        EXPECT_LT(std::abs(mesh.normals[v].x), 0.5f * s) << "ridge vertex at y = " << mesh.positions[v].y;
        if (std::abs(mesh.positions[v].y - 1.0f) < 1e-6f) {
            EXPECT_NEAR(mesh.normals[v].x, 0.0f, 1e-5f) << "the ridge's centre";
        }
    }
    EXPECT_EQ(ridge, 3);
}

TEST(MeshLoader, OpenBoundariesAreCountedAsEdgesAndLoops) {
    // A cube of 8 shared corners (OBJ), 12 triangles; counted by hand: removing the two triangles of the top
    // face opens a square hole (4 boundary edges, 1 loop), removing one triangle of the bottom face a
    // triangular one (3 edges, 1 loop): 7 edges, 2 loops. The closed cube has none.
    const std::string corners = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\n";
    const std::vector<std::string> faces = {
        "f 1 3 2\nf 1 4 3\n",                                                        // bottom (z = 0)
        "f 5 6 7\nf 5 7 8\n",                                                        // top (z = 1)
        "f 1 2 6\nf 1 6 5\nf 2 3 7\nf 2 7 6\nf 3 4 8\nf 3 8 7\nf 4 1 5\nf 4 5 8\n"}; // sides
    const std::filesystem::path folder = std::filesystem::temp_directory_path() / "lightskin_open_boundaries";
    std::filesystem::create_directories(folder);
    const auto write = [&](const std::string& name, const std::string& text) {
        std::ofstream(folder / name) << text;
        return folder / name;
    };
    const auto closed = loadModel(write("closed.obj", corners + faces[0] + faces[1] + faces[2]));
    EXPECT_EQ(closed.report.boundaryEdges, 0u);
    EXPECT_EQ(closed.report.boundaryLoops, 0u);
    EXPECT_EQ(lightskin::render::openBoundaryWarning("closed.obj", closed.report), "");
    const auto open = loadModel(write("open.obj", corners + "f 1 3 2\n" + faces[2]));
    EXPECT_EQ(open.report.boundaryEdges, 7u);
    EXPECT_EQ(open.report.boundaryLoops, 2u);
    const std::string warning = lightskin::render::openBoundaryWarning("open.obj", open.report);
    EXPECT_NE(warning.find("open.obj"), std::string::npos);
    EXPECT_NE(warning.find("2 hole(s), 7 boundary edges"), std::string::npos) << warning;
    // The loader splits the cube's corners at its 90 degree creases (24 vertices): corners are joined by position,
    // so the splits are no boundary.
    EXPECT_GT(closed.vertexCount(), 8u);
    std::filesystem::remove_all(folder);

    // The bunny scan (bun_zipper_res4.ply): counted from the file with a script (Python, corners joined by
    // position, each corner set once as the loader keeps it): 907 triangles, 53 boundary edges in 21 loops (its
    // scan holes; 46 further edges are shared by more than two triangles, non-manifold, not open).
    const auto bunny = loadModel(dataPath("meshes/bun_zipper_res4.ply"));
    EXPECT_EQ(bunny.report.boundaryEdges, 53u);
    EXPECT_EQ(bunny.report.boundaryLoops, 21u);

    // findOpenBoundaries on a hand-made mesh: one triangle is one loop of 3 edges; two triangles sharing only a
    // corner are one loop (their rims touch) of 6 edges.
    TriangleMesh one;
    one.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {-1, 0, 0}, {0, -1, 0}};
    one.indices = {0, 1, 2};
    EXPECT_EQ(lightskin::render::findOpenBoundaries(one).edges, 3u);
    EXPECT_EQ(lightskin::render::findOpenBoundaries(one).loops, 1u);
    one.indices = {0, 1, 2, 0, 3, 4};
    EXPECT_EQ(lightskin::render::findOpenBoundaries(one).edges, 6u);
    EXPECT_EQ(lightskin::render::findOpenBoundaries(one).loops, 1u);
}
