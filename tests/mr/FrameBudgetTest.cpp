// mr::FrameBudget without GL: the choice logic against independent enumeration, the monotonicity
// of error in the budget, what cannot change the image, and the scene analysis (glossy, convex).
#include <lightskin/core/Error.h>
#include <lightskin/core/TriangleMesh.h>
#include <lightskin/mr/FrameBudget.h>

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

namespace lightskin::mr {
namespace {

/// "The machine": the prior's formulas with other constants per technique plus a fixed cost per
/// frame the model does not have, so that predictions for configurations never run are wrong.
struct TrueCosts {
    double lightSkinScale = 3.0, bruteForceScale = 0.4, giOverheadMs = 2.0, otherMs = 7.0;
    StageCosts operator()(const FrameBudget& model, const QualitySettings& c, const FrameStats& stats) const {
        const double scale = c.technique == Technique::LightSkin ? lightSkinScale * 1.0e-5 : bruteForceScale * 8.2e-6;
        return {giOverheadMs + scale * model.modelUnits(c, stats), otherMs};
    }
};

const FrameStats kStats{4800.0, 4, 6000.0}; // 80x60 VALs at stride 4, 6000 covered pixels (a 320x240 view)

TEST(FrameBudgetTest, FirstMeasurementOfAConfigurationReplacesThePrior) {
    BudgetOptions options;
    options.budgetMs = 100.0;
    FrameBudget budget(options, {true, true, 2}, {});
    const TrueCosts truth;
    const QualitySettings ran = budget.current();
    const StageCosts measured = truth(budget, ran, kStats);
    budget.observe(ran, kStats, measured);
    // Exact up to rounding: measured / units * units + other.
    EXPECT_NEAR(budget.predictMs(ran, kStats), measured.giMs + measured.otherMs,
                1e-9 * (measured.giMs + measured.otherMs));
    // Another LightSkin configuration: the prior scaled by the measured ratio (so within the overhead).
    QualitySettings other = ran;
    other.sparsePoints = 256;
    const StageCosts otherTruth = truth(budget, other, kStats);
    EXPECT_NEAR(budget.predictMs(other, kStats), otherTruth.giMs + otherTruth.otherMs,
                truth.giOverheadMs * 1.0001 + 1e-9); // the one term the model lacks, scaled at most by 1
}

/// Drives a budget on a steady frame like a session would, from the true costs.
FrameBudget settle(double budgetMs, int frames) {
    BudgetOptions options;
    options.budgetMs = budgetMs;
    FrameBudget budget(options, {true, true, 2}, {});
    const TrueCosts truth;
    for (int f = 0; f < frames; ++f) {
        const QualitySettings c = budget.choose(kStats);
        budget.observe(c, kStats, truth(budget, c, kStats));
    }
    return budget;
}

TEST(FrameBudgetTest, SteadyFramesMeetTheBudgetAfterWarmUp) {
    const TrueCosts truth;
    for (double budgetMs : {15.0, 30.0, 60.0, 200.0, 1000.0, 10000.0}) {
        FrameBudget budget = settle(budgetMs, 30);
        // Steady state: the configuration stays and its measured cost is what the truth says. The
        // budget keeps a configuration only while its own measurement (exact: deterministic costs,
        // first measurement replaces the prior, later ones blend in the same value) fits, so the
        // tolerance is rounding only -- unless nothing fits, then it runs the cheapest.
        const QualitySettings c = budget.choose(kStats);
        const StageCosts cost = truth(budget, c, kStats);
        double cheapest = std::numeric_limits<double>::infinity();
        for (const QualitySettings& q : budget.candidates()) {
            const StageCosts t = truth(budget, q, kStats);
            cheapest = std::min(cheapest, t.giMs + t.otherMs);
        }
        if (cheapest <= budgetMs * 0.9) {
            EXPECT_LE(cost.giMs + cost.otherMs, budgetMs * (1.0 + 1e-12)) << budgetMs << " ms: " << describe(c);
        }
        EXPECT_EQ(budget.choose(kStats), c) << "not settled at " << budgetMs << " ms";
    }
}

TEST(FrameBudgetTest, ChoosesTheLeastErrorThatFits) {
    FrameBudget budget = settle(120.0, 10);
    const QualitySettings current = budget.current();
    const QualitySettings chosen = budget.choose(kStats);
    // Independent enumeration: least error among those predicted to fit (current: the budget,
    // others: the switch margin), ties to the cheaper.
    double bestError = std::numeric_limits<double>::infinity();
    for (const QualitySettings& q : budget.candidates()) {
        const double limit = q == current ? 120.0 : 0.9 * 120.0;
        if (budget.predictMs(q, kStats) <= limit) bestError = std::min(bestError, budget.expectedError(q));
    }
    ASSERT_TRUE(std::isfinite(bestError));
    EXPECT_EQ(budget.expectedError(chosen), bestError) << describe(chosen);
}

TEST(FrameBudgetTest, ATighterBudgetNeverPicksALowerErrorThanALooserOne) {
    // One learned state (a warm-up at a middle budget), then every budget from tight to loose.
    const FrameBudget learned = settle(100.0, 12);
    double previousError = std::numeric_limits<double>::infinity();
    int distinct = 0;
    for (double budgetMs = 1.0; budgetMs < 1.0e5; budgetMs *= 1.25) {
        FrameBudget budget = learned;
        budget.setBudgetMs(budgetMs);
        const double error = budget.expectedError(budget.choose(kStats));
        EXPECT_LE(error, previousError) << budgetMs << " ms";
        if (error < previousError) ++distinct;
        previousError = error;
    }
    EXPECT_GE(distinct, 3) << "the sweep should cross several configurations";
}

TEST(FrameBudgetTest, ChannelsTheSceneCannotUseAreNeverChosen) {
    BudgetOptions options;
    options.budgetMs = 1.0e6;
    const FrameBudget budget(options, {false, false, 1}, {});
    for (const QualitySettings& q : budget.candidates()) {
        EXPECT_FALSE(q.glossy) << describe(q);
        EXPECT_FALSE(q.occlusion) << describe(q);
    }
    // And the error model does not charge for them.
    EXPECT_EQ(budget.expectedError({Technique::LightSkin, 1024, 4, false, false}),
              budget.expectedError({Technique::LightSkin, 1024, 4, true, true}));
}

TEST(FrameBudgetTest, MeasuredErrorsReplaceThePrior) {
    BudgetOptions options;
    options.budgetMs = 1.0e6;
    FrameBudget budget(options, {true, true, 2}, {});
    const QualitySettings q{Technique::LightSkin, 256, 8, true, true};
    budget.observeError(q, 0.5);
    EXPECT_EQ(budget.expectedError(q), 0.5);
    // With all costs far below the budget, the worse-measured configuration is not chosen.
    EXPECT_FALSE(budget.choose(kStats) == q);
}

TEST(FrameBudgetTest, RejectsBadBudgets) {
    BudgetOptions options;
    options.budgetMs = 0.0;
    EXPECT_THROW(FrameBudget(options, {}, {}), Error);
    options.budgetMs = std::numeric_limits<double>::quiet_NaN();
    EXPECT_THROW(FrameBudget(options, {}, {}), Error);
    options.budgetMs = 10.0;
    options.valStrideChoices.clear();
    EXPECT_THROW(FrameBudget(options, {}, {}), Error);
}

TriangleMesh cube() {
    TriangleMesh m;
    for (int i = 0; i < 8; ++i)
        m.positions.push_back(glm::vec3(float(i & 1), float((i >> 1) & 1), float((i >> 2) & 1)));
    // 12 triangles, counter-clockwise seen from outside.
    m.indices = {0, 2, 1, 1, 2, 3, 4, 5, 6, 5, 7, 6, 0, 1, 4, 1, 5, 4,
                 2, 6, 3, 3, 6, 7, 0, 4, 2, 2, 4, 6, 1, 3, 5, 3, 7, 5};
    m.normals.assign(8, glm::vec3(0, 0, 1));
    return m;
}

TEST(FrameBudgetTest, SceneNeedsFromTheInstances) {
    const TriangleMesh box = cube();
    TriangleMesh dented = box;
    dented.positions[7] = glm::vec3(0.6f, 0.6f, 0.6f); // a corner pushed inside: not convex
    gi::MeshInstance a;
    a.mesh = &box;
    SceneNeeds needs = sceneNeeds(std::span(&a, 1));
    EXPECT_FALSE(needs.occlusion) << "one convex object cannot occlude itself";
    EXPECT_FALSE(needs.glossy);
    a.material.specularAlbedo = glm::vec3(0.0f, 0.1f, 0.0f);
    EXPECT_TRUE(sceneNeeds(std::span(&a, 1)).glossy);
    gi::MeshInstance b;
    b.mesh = &dented;
    EXPECT_TRUE(sceneNeeds(std::span(&b, 1)).occlusion);
    const gi::MeshInstance two[2] = {a, a};
    needs = sceneNeeds(two);
    EXPECT_TRUE(needs.occlusion) << "two objects can occlude each other";
    EXPECT_EQ(needs.objects, 2);
}

} // namespace
} // namespace lightskin::mr
