// gi.backend "auto": the classification of GL_RENDERER strings as the drivers print them, and the choice of
// backend with its reason for every technique, setting and override (gi::classifyGlRenderer,
// gi::chooseBackend). The renderer strings are the drivers' own (Mesa 22-24, NVIDIA, VMware, Windows).
#include <lightskin/gi/Techniques.h>
#include <lightskin/gi/common/Technique.h>

#include <gtest/gtest.h>

#include <iterator>
#include <optional>
#include <set>
#include <string>

using namespace lightskin;
using gi::Backend;
using gi::BackendChoice;
using gi::BackendReason;
using gi::BackendSetting;
using gi::GlRenderer;

TEST(BackendChoiceTest, SoftwareRasterizersAreRecognisedByName) {
    for (const char* renderer : {
             "llvmpipe (LLVM 15.0.6, 256 bits)", // Mesa's llvmpipe (Debian 12, this repository's CI)
             "llvmpipe (LLVM 17.0.6, 128 bits)",
             "softpipe",            // Mesa's reference rasterizer (GALLIUM_DRIVER=softpipe)
             "Software Rasterizer", // swrast's GL_RENDERER (classic Mesa)
             "Mesa X11 swrast",     // swrast named as the driver
             "zink Vulkan 1.3(llvmpipe (LLVM 15.0.6, 256 bits))", // GL on Vulkan on lavapipe: still the CPU
             "Google SwiftShader",
             "D3D12 (Microsoft Basic Render Driver)", // WSL's WARP
             "GDI Generic",
             "Apple Software Renderer",
             "LLVMPIPE (upper case)",
         })
        EXPECT_EQ(gi::classifyGlRenderer(renderer), GlRenderer::SoftwareRasterizer) << renderer;
}

TEST(BackendChoiceTest, GpusAndVirtualGpusAreNotSoftware) {
    for (const char* renderer : {
             "Mesa Intel(R) UHD Graphics 620 (KBL GT2)",
             "NVIDIA GeForce RTX 3080/PCIe/SSE2",
             "AMD Radeon RX 6800 XT (navi21, LLVM 15.0.6, DRM 3.49, 6.1.0-13-amd64)", // "LLVM" alone is the shader
                                                                                      // compiler
             "SVGA3D; build: RELEASE;  LLVM;",            // VMware's virtual GPU: the host's
             "virgl (NVIDIA GeForce GTX 1080/PCIe/SSE2)", // VirGL: the host's GPU
             "D3D12 (Intel(R) UHD Graphics 620)",         // WSL on a GPU
             "Apple M1",
         })
        EXPECT_EQ(gi::classifyGlRenderer(renderer), GlRenderer::Gpu) << renderer;
}

TEST(BackendChoiceTest, AnEmptyRendererIsUnknown) {
    EXPECT_EQ(gi::classifyGlRenderer(""), GlRenderer::Unknown);
    EXPECT_EQ(gi::classifyGlRenderer("  "), GlRenderer::Unknown);
}

TEST(BackendChoiceTest, AutoPicksTheCpuOnlyOnASoftwareRasterizer) {
    const auto autoFor = [](GlRenderer renderer) {
        return gi::chooseBackend(gi::Technique::LightSkin, BackendSetting::Auto, std::nullopt, renderer);
    };
    EXPECT_EQ(autoFor(GlRenderer::SoftwareRasterizer),
              (BackendChoice{Backend::Cpu, BackendReason::SoftwareRasterizer}));
    EXPECT_EQ(autoFor(GlRenderer::Gpu), (BackendChoice{Backend::Gl, BackendReason::Gpu}));
    EXPECT_EQ(autoFor(GlRenderer::Unknown), (BackendChoice{Backend::Gl, BackendReason::UnknownRenderer}));
    // The command line's auto is auto too, over a scene's explicit backend.
    EXPECT_EQ(gi::chooseBackend(gi::Technique::LightSkin, BackendSetting::Gl, BackendSetting::Auto,
                                GlRenderer::SoftwareRasterizer),
              (BackendChoice{Backend::Cpu, BackendReason::SoftwareRasterizer}));
}

TEST(BackendChoiceTest, TheSceneAndTheCommandLineOverrideAuto) {
    for (const GlRenderer renderer : {GlRenderer::SoftwareRasterizer, GlRenderer::Gpu, GlRenderer::Unknown}) {
        const auto choose = [&](BackendSetting scene, std::optional<BackendSetting> commandLine) {
            return gi::chooseBackend(gi::Technique::LightSkin, scene, commandLine, renderer);
        };
        EXPECT_EQ(choose(BackendSetting::Gl, std::nullopt), (BackendChoice{Backend::Gl, BackendReason::SceneSetting}));
        EXPECT_EQ(choose(BackendSetting::Cpu, std::nullopt),
                  (BackendChoice{Backend::Cpu, BackendReason::SceneSetting}));
        // The command line wins over the scene, either way round.
        EXPECT_EQ(choose(BackendSetting::Cpu, BackendSetting::Gl),
                  (BackendChoice{Backend::Gl, BackendReason::CommandLine}));
        EXPECT_EQ(choose(BackendSetting::Gl, BackendSetting::Cpu),
                  (BackendChoice{Backend::Cpu, BackendReason::CommandLine}));
        EXPECT_EQ(choose(BackendSetting::Auto, BackendSetting::Cpu),
                  (BackendChoice{Backend::Cpu, BackendReason::CommandLine}));
    }
}

TEST(BackendChoiceTest, TechniquesWithoutACpuBackendStayOnGlAndSaySo) {
    for (const gi::Technique technique : gi::kTechniques) {
        if (gi::runsOn(technique, Backend::Cpu)) continue;
        for (const BackendSetting asked : {BackendSetting::Auto, BackendSetting::Cpu}) {
            EXPECT_EQ(gi::chooseBackend(technique, asked, std::nullopt, GlRenderer::SoftwareRasterizer),
                      (BackendChoice{Backend::Gl, BackendReason::TechniqueRunsOnlyOnGl}))
                << gi::toString(technique) << " " << gi::toString(asked);
            EXPECT_EQ(gi::chooseBackend(technique, BackendSetting::Gl, asked, GlRenderer::SoftwareRasterizer),
                      (BackendChoice{Backend::Gl, BackendReason::TechniqueRunsOnlyOnGl}))
                << gi::toString(technique) << " --backend " << gi::toString(asked);
        }
        // Asked for gl by name: the setting is the reason.
        EXPECT_EQ(gi::chooseBackend(technique, BackendSetting::Gl, std::nullopt, GlRenderer::SoftwareRasterizer),
                  (BackendChoice{Backend::Gl, BackendReason::SceneSetting}));
    }
}

TEST(BackendChoiceTest, EveryReasonHasItsOwnSentence) {
    const BackendReason reasons[] = {BackendReason::SceneSetting,       BackendReason::CommandLine,
                                     BackendReason::SoftwareRasterizer, BackendReason::Gpu,
                                     BackendReason::UnknownRenderer,    BackendReason::TechniqueRunsOnlyOnGl};
    std::set<std::string> sentences;
    for (const BackendReason reason : reasons) {
        const std::string sentence(gi::toString(reason));
        EXPECT_GT(sentence.size(), 10u) << sentence;
        EXPECT_NE(sentence, "?");
        sentences.insert(sentence);
    }
    EXPECT_EQ(sentences.size(), std::size(reasons));
    EXPECT_NE(std::string(gi::toString(BackendReason::SoftwareRasterizer)).find("software rasterizer"),
              std::string::npos);
}

// gi.valTreeThreshold "auto" (the default): the cut where it was measured to pay, on the backend the pipeline
// resolved; an explicit value is taken as it is on both backends, in every frame.
TEST(BackendChoiceTest, ValTreeAutoCutsOnGlFromTheCrossoverAndNeverOnTheCpu) {
    gi::GiSettings settings;
    ASSERT_FALSE(settings.valTreeThreshold.has_value()) << "auto is the default";
    settings.backend = BackendSetting::Gl;
    const gi::LightSkinSettings gl = gi::configFor(settings).lightSkin;
    EXPECT_EQ(gl.valTreeThreshold, gi::kAutoValTreeThreshold);
    EXPECT_EQ(gl.valTreeMinVals, gi::kGlValTreeMinVals);
    settings.backend = BackendSetting::Cpu;
    const gi::LightSkinSettings cpu = gi::configFor(settings).lightSkin;
    EXPECT_EQ(cpu.valTreeThreshold, 0.0f) << "the CPU backend's cut never paid: the flat gather";
    for (const BackendSetting backend : {BackendSetting::Gl, BackendSetting::Cpu}) {
        settings.backend = backend;
        settings.valTreeThreshold = 0.2f;
        const gi::LightSkinSettings chosen = gi::configFor(settings).lightSkin;
        EXPECT_EQ(chosen.valTreeThreshold, 0.2f);
        EXPECT_EQ(chosen.valTreeMinVals, 0u) << "an explicit threshold cuts in every frame";
        settings.valTreeThreshold = 0.0f;
        EXPECT_EQ(gi::configFor(settings).lightSkin.valTreeThreshold, 0.0f);
    }
}
