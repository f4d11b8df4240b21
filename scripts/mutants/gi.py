"""Mutant catalogue of the GI for scripts/mutate_gi.py (the tool's docstring says how it is used).

Each mutant: id, area, what (the formula error), edits, tests (binaries, or 'binary:gtest filter', that
must fail on it), optional agree (tests that must still pass: a shared mutant is applied alike to every
implementation, so their comparisons with each other must not see it; if they do, the edits are not
alike and the mutant is invalid), optional quick (in the --quick subset) and equivalent (the reason it
cannot be caught). An edit: file, fn (a regex for the enclosing function's signature; its body is the
brace block after it), then text (literal) or regex (re syntax, groups usable in `to`) that must occur
exactly once in that body, and its replacement `to`. Killers are never golden-image tests.
"""

MATH = 'gi/lightskin/shaders/lightskin_math.glsl'
KERNELS = 'gi/lightskin/src/cpu/CpuGatherKernels.cpp'
PAPER = 'tests/gi/reference/PaperReference.cpp'
TRUTH_GL = 'gi/reference/src/RayTracedGroundTruth.cpp'

# the independent references of the GI core: closed forms and PaperReference (written from the paper)
INDEPENDENT = ['gi_paper_reference_test', 'gi_gather_gl_test']
# LightSkin against the Embree ray tracer (gi::RayTracedGroundTruth), budgets derived from the scene
EMBREE = ['gi_truth_gl_test', 'gi_near_contact_gl_test']
# the implementations' comparisons with each other: a shared mutant must leave them passing. The GPU is
# compared stage by stage with gi::reference and PaperReference, the CPU backend with gi::reference.
# Not PaperReference.SharedMathReferenceMatchesTheIndependentOneAtEveryStage: its eq. 10 stage holds the
# two doubles to 1e-8, but PaperReference's horizon factor (G9) is a quadrature accurate to 1e-6 by
# design, which shows wherever a mutant moves a VPL into the horizon band (shared-irr-cos, shared-wd-cos).
AGREE = ['gi_gather_gl_test:*LightSkinSetupGLTest.EveryStageMatchesBothDoubleReferences*',
         'gi_cpu_lightskin_gl_test:*CpuLightSkinSetupGLTest.EveryStageMatchesTheDoubleReference*']


def edit(file, fn, text, to):
    return {'file': file, 'fn': fn, 'text': text, 'to': to}


def mutant(id, area, what, edits, tests, **extra):
    return dict(id=id, area=area, what=what, edits=edits, tests=tests, **extra)


GATHER_SAMPLE = r'GatherSample ls_gatherSample\('
DISC_TERMS = r'DiscTerms ls_discTerms\('
RENORM_D = r'Vpl ls_renormaliseDiffuse\('
RENORM_S = r'Vpl ls_renormaliseGlossy\('
OCCLUDER = r'real ls_occluderAmount\('
WEIGHTS = r'VertexWeights ls_vertexWeightsOf\('
CPU_GATHER = r'\bGatherGroup\(const ValArrays'
CPU_OCCLUSION = r'\bOcclusionGroup\(const OcclusionReceivers'
PAPER_GATHER = r'PointGather gather\('
PAPER_OCCLUSION = r'glm::dvec2 occlusion\('
PAPER_WEIGHTS = r'\bvertexWeights\(const glm::dvec3& vertex'
MAIN = r'void main\(\)'

LIGHTSKIN_MATH = [
    mutant('math-w-r2', 'lightskin math', 'eq. 3: w without r^2',
           [edit(MATH, GATHER_SAMPLE, 'const real w = t.r2 * t.g;', 'const real w = t.g;')], INDEPENDENT, quick=True),
    mutant('math-mirror-2', 'lightskin math', 'eq. 5: mirror direction without the factor 2',
           [edit(MATH, r'real ls_cosGamma\(', '2.0 * dot(n, toLight) * n', 'dot(n, toLight) * n')], INDEPENDENT),
    mutant('math-ws-diffuse', 'lightskin math', 'eq. 7: W_s with the diffuse weight',
           [edit(MATH, GATHER_SAMPLE, 'epsL + w * lobe', 'epsL + w * t.cosI')], INDEPENDENT),
    mutant('math-rbar-invw', 'lightskin math', 'eq. 7: rbar^2 not divided by W',
           [edit(MATH, RENORM_D, 'v.r2 = max(sumR2 * invW, 0.0);', 'v.r2 = max(sumR2, 0.0);')], INDEPENDENT),
    mutant('math-renorm-cos', 'lightskin math', 'eq. 11: L\'\'_d multiplied by cos instead of divided',
           [edit(MATH, RENORM_D, '/ max(cosT, kMinRenormCos)', '* max(cosT, kMinRenormCos)')], INDEPENDENT),
    mutant('math-glossy-d', 'lightskin math', 'eq. 11: glossy D without rbar^2',
           [edit(MATH, RENORM_S, 'max(d2 + v.r2, kTinyLength2)', 'max(d2, kTinyLength2)')], INDEPENDENT),
    mutant('math-apply-d', 'lightskin math', 'eq. 10: diffuse D without rbar^2',
           [edit(MATH, r'rvec3 ls_applyDiffuse\(', 'max(d2 + v.r2, kTinyLength2)', 'max(d2, kTinyLength2)')],
           INDEPENDENT + ['gi_gather_reference_test']),
    mutant('math-eq13-norm', 'lightskin math', 'eq. 13: weights divided by W_v + 1',
           [edit(MATH, WEIGHTS, 'r.w[j] = r.w[j] / total;', 'r.w[j] = r.w[j] / (total + 1.0);')], INDEPENDENT),
    mutant('math-occ-side', 'lightskin math', 'eq. 14: occluder quad side = area, not sqrt(area)',
           [edit(MATH, OCCLUDER, 'const real side = sqrt(area);', 'const real side = area;')], INDEPENDENT),
    mutant('math-target-cos2', 'lightskin math', 'sec. 3.3: S_o area with cos(theta_i) twice',
           [edit(MATH, r'OcclusionTarget ls_occlusionTarget\(', 'kPi * cosI * r2', 'kPi * cosI * cosI * r2')],
           INDEPENDENT),
    mutant('math-so-variance', 'lightskin math', 'sec. 3.3: S_o radius = variance, not sigma',
           [edit(MATH, RENORM_D, 'sqrt(max(max(variance.x, variance.y), variance.z))',
                 'max(max(variance.x, variance.y), variance.z)')], INDEPENDENT),
    mutant('math-g9-sign', 'lightskin math', 'G9: horizon factor with the sign of x cos(theta) flipped',
           [edit(MATH, r'real ls_horizonCos\(', 'clamp(-x * cosT', 'clamp(x * cosT')], INDEPENDENT),
    mutant('math-g8-floor', 'lightskin math', 'G8: floor subtracts the VPL distance, not its square',
           [edit(MATH, r'real ls_vertexR2Floor\(', 'max(r2, minD - dot(o, o))', 'max(r2, minD - sqrt(dot(o, o)))')],
           INDEPENDENT + ['gi_gather_reference_test']),
    mutant('math-eq12-scale', 'lightskin math', 'eq. 12: distance term times 2',
           [edit(MATH, WEIGHTS, '? distanceTerm * clamp', '? 2.0 * distanceTerm * clamp')], INDEPENDENT,
           equivalent='eq. 13 divides every weight by their sum W_v, so a common factor cancels exactly (and '
                      'the G6a fallback tests total > 0, unchanged by a positive factor)'),
]

GATHER_SHADERS = [
    mutant('gpu-ck', 'gather shaders', 'eq. 5: c_k = c k in the fragment gather',
           [edit('gi/lightskin/shaders/gather_sparse.frag', MAIN, 'uC * (k + 1.0)', 'uC * k')], ['gi_gather_gl_test'],
           quick=True),
    mutant('gpu-normal-model', 'gather shaders', 'eq. 12: vertex normals not transformed to world',
           [edit('gi/lightskin/shaders/gather_interpolate.comp', MAIN, 'normalize(uNormalFromModel * vin.normal.xyz)',
                 'normalize(vin.normal.xyz)')], ['gi_gather_gl_test']),
    mutant('gpu-shade-pi', 'gather shaders', 'eq. 10: rho_d without 1/pi in the shading',
           [edit('gi/lightskin/shaders/gather_shade.frag', MAIN, 'vGlossyPosition.w) / kPi;', 'vGlossyPosition.w);')],
           ['gi_gather_gl_test']),
    mutant('gpu-glossy-radius', 'gather shaders', 'glossy VPL handed S_o radius 1 instead of 0 in the shading',
           [edit('gi/lightskin/shaders/gather_shade.frag', MAIN, 's.sphereRadius = 0.0;', 's.sphereRadius = 1.0;')],
           ['gi_gather_gl_test'],
           equivalent='ls_applyGlossy never reads the VPL\'s sphereRadius (G9 applies to the diffuse channel '
                      'only), so the stored value is dead'),
]

CPU_KERNELS = [
    mutant('cpu-wd-r2', 'CPU kernels', 'eq. 7: W_d term without r^2 in the Highway gather',
           [edit(KERNELS, CPU_GATHER, 'const V wD = hn::Mul(r2, gCos);', 'const V wD = gCos;')],
           ['gi_cpu_lightskin_gl_test'], quick=True),
    mutant('cpu-ck', 'CPU kernels', 'eq. 5: red glossy sum without c_k',
           [edit(KERNELS, CPU_GATHER, 'AddBlock(d, s + 8 * lanes, hn::Mul(ck, gR));',
                 'AddBlock(d, s + 8 * lanes, gR);')],
           ['gi_cpu_lightskin_gl_test']),
    mutant('cpu-cos-clamp', 'CPU kernels', 'eq. 4: cos(theta_i) not clamped at 0 (light from below the horizon)',
           [edit(KERNELS, CPU_GATHER, 'hn::Mul(hn::Max(Dot(nx, ny, nz, ox, oy, oz), zero), invLength2)',
                 'hn::Mul(Dot(nx, ny, nz, ox, oy, oz), invLength2)')], ['gi_cpu_lightskin_gl_test']),
    mutant('cpu-occ-tb', 'CPU kernels', 'eq. 14: occluder centre t/b swapped in the Highway occlusion',
           [edit(KERNELS, CPU_OCCLUSION, 'ucx = Dot(ux, uy, uz, tx, ty, tz), ucy = Dot(ux, uy, uz, bx, by, bz)',
                 'ucx = Dot(ux, uy, uz, bx, by, bz), ucy = Dot(ux, uy, uz, tx, ty, tz)')],
           ['gi_cpu_lightskin_gl_test']),
    mutant('cpu-depth-clamp', 'CPU kernels', 'sec. 3.3: occluder depth factor not clamped to 1',
           [edit(KERNELS, r'HWY_INLINE V TargetAmount\(',
                 'hn::Min(hn::Max(hn::Mul(hn::Sub(dist, dy), invRadius), zero), hn::Set(d, 1.0f))',
                 'hn::Max(hn::Mul(hn::Sub(dist, dy), invRadius), zero)')], ['gi_cpu_lightskin_gl_test']),
]

# Applied alike to the shader math (GPU and gi::reference), the CPU backend's kernels and PaperReference:
# every comparison between implementations passes, only the Embree truth can object.
SHARED = [
    mutant('shared-irr-cos', 'shared (truth)', 'eq. 4: irradiance without cos(theta_i) (horizon kept)',
           [edit(MATH, GATHER_SAMPLE, 's.irradiance = valid ? mw * t.cosI',
                 's.irradiance = valid ? mw * (t.cosI > 0.0 ? 1.0 : 0.0)'),
            edit(KERNELS, CPU_GATHER, 'const V gCos = hn::Mul(g, cosI);',
                 'const V gCos = hn::IfThenElseZero(hn::Gt(cosI, zero), g);'),
            edit(KERNELS, CPU_GATHER, 'const V wD = hn::Mul(r2, gCos);', 'const V wD = hn::Mul(r2, hn::Mul(g, cosI));'),
            edit(PAPER, PAPER_GATHER, 'irradiance += exitance * w * cosI;',
                 'irradiance += exitance * w * (cosI > 0.0 ? 1.0 : 0.0);')],
           EMBREE, agree=AGREE),
    mutant('shared-disc-r2', 'shared (truth)', 'eq. 3: point light 1/d^2 instead of the disc 1/(r^2 + d^2)',
           [edit(MATH, DISC_TERMS, 'cosJ / max(t.r2 + d2, kTinyLength2)', 'cosJ / max(d2, kTinyLength2)'),
            edit(KERNELS, CPU_GATHER, 'const V b = hn::Add(r2, d2);', 'const V b = d2;'),
            edit(PAPER, r'double discWeight\(', 'r2 * cosJ / (r2 + d2)', 'r2 * cosJ / d2')],
           EMBREE, agree=AGREE),
    mutant('shared-lobe-k1', 'shared (truth)', 'eq. 5: cos^(k+1) in the gather',
           [edit(MATH, GATHER_SAMPLE, 'ls_cosPow(ls_cosGamma(n, t.toLight, toEye), k)',
                 'ls_cosPow(ls_cosGamma(n, t.toLight, toEye), k + 1.0)'),
            edit(KERNELS, CPU_GATHER, 'const V k = hn::LoadU(d, &r.k[i]);',
                 'const V k = hn::Add(hn::LoadU(d, &r.k[i]), hn::Set(d, 1.0f));'),
            edit(PAPER, PAPER_GATHER, 'toEye), x.exponent)', 'toEye), x.exponent + 1.0)')],
           EMBREE, agree=AGREE),
    mutant('shared-wd-cos', 'shared (truth)', 'eq. 7: W_d without cos(theta_i) (VALs above the horizon)',
           [edit(MATH, GATHER_SAMPLE, 'epsL + w * t.cosI', 'epsL + (t.cosI > 0.0 ? w : 0.0)'),
            edit(KERNELS, CPU_GATHER, 'const V wD = hn::Mul(r2, gCos);',
                 'const V wD = hn::IfThenElseZero(hn::Gt(cosI, zero), hn::Mul(r2, g));'),
            edit(PAPER, PAPER_GATHER, 'options.epsilonL + w * cosI;', 'options.epsilonL + (cosI > 0.0 ? w : 0.0);')],
           EMBREE, agree=AGREE),
    mutant('shared-eq12-normal', 'shared (truth)', 'eq. 12: normal term dropped',
           [edit(MATH, WEIGHTS, '? distanceTerm * clamp(cosN[j], 0.0, 1.0) :', '? distanceTerm :'),
            edit(PAPER, PAPER_WEIGHTS, ': 1.0) * cosine[j];', ': 1.0);')],
           EMBREE, agree=AGREE, quick=True),
    # (d / d_max)^2, not d^2 / d_max^2: the farthest neighbour's weight stays exactly 0 in float as in double
    # (d^2 / d_max^2 can round to a tiny positive weight on the GPU alone, which changes the set of
    # contributing neighbours that G8 and G10 take their minimum and maximum over)
    mutant('shared-eq12-squared', 'shared (truth)', 'eq. 12: distance term squared',
           [edit(MATH, WEIGHTS, 'max(1.0 - dist[j] / dMax, 0.0)',
                 'max(1.0 - (dist[j] / dMax) * (dist[j] / dMax), 0.0)'),
            edit(PAPER, PAPER_WEIGHTS, '1.0 - distance[j] / dMax',
                 '1.0 - (distance[j] / dMax) * (distance[j] / dMax)')],
           EMBREE, agree=AGREE),
    mutant('shared-occ-tb', 'shared (truth)', 'eq. 14: occluder centre t/b swapped',
           [edit(MATH, OCCLUDER, 'rvec2(dot(u, t), dot(u, b))', 'rvec2(dot(u, b), dot(u, t))'),
            edit(KERNELS, CPU_OCCLUSION, 'ucx = Dot(ux, uy, uz, tx, ty, tz), ucy = Dot(ux, uy, uz, bx, by, bz)',
                 'ucx = Dot(ux, uy, uz, bx, by, bz), ucy = Dot(ux, uy, uz, tx, ty, tz)'),
            edit(PAPER, PAPER_OCCLUSION, 'centre(glm::dot(e, t), glm::dot(e, b))',
                 'centre(glm::dot(e, b), glm::dot(e, t))')],
           EMBREE, agree=AGREE),
    mutant('shared-occ-cos', 'shared (truth)', 'sec. 3.3: occluder area without cos(theta_i)',
           [edit(MATH, OCCLUDER, 'max(r2 + d2, kTinyLength2) * cosI;', 'max(r2 + d2, kTinyLength2);'),
            edit(KERNELS, CPU_OCCLUSION, 'const V cosI = hn::Mul(nDotV, inv);', 'const V cosI = hn::Set(d, 1.0f);'),
            edit(PAPER, PAPER_OCCLUSION, '/ (ry2 + dy * dy) * cosI;', '/ (ry2 + dy * dy);')],
           EMBREE, agree=AGREE),
]

VAL_SHADER = 'gi/common/shaders/val_from_depth.comp'
VAL_CPU = 'gi/common/src/CpuValGenerator.cpp'
VAL_GENERATOR = [
    mutant('val-gpu-cosalpha', 'VAL generator', 'VAL area without cos(alpha) of the view ray (GPU)',
           [edit(VAL_SHADER, MAIN, 'footprint * cosAlpha / cosTheta', 'footprint / cosTheta')],
           ['gi_val_generator_test'], quick=True),
    mutant('val-gpu-orient', 'VAL generator', 'normal oriented away from the camera (GPU)',
           [edit(VAL_SHADER, MAIN, 'if (dot(n, ray) > 0.0) n = -n;', 'if (dot(n, ray) < 0.0) n = -n;')],
           ['gi_val_generator_test']),
    mutant('val-gpu-flux-pi', 'VAL generator', 'flux without pi (radiance taken as exitance, GPU)',
           [edit(VAL_SHADER, MAIN, 'vec4(kPi * exposure * colour * area', 'vec4(exposure * colour * area')],
           ['gi_val_generator_test']),
    mutant('val-cpu-flux-pi', 'VAL generator', 'flux without pi (CPU generator)',
           [edit(VAL_CPU, r'bool valFromDepth\(', 'kPi * in.exposure * colour * area', 'in.exposure * colour * area')],
           ['gi_cpu_val_generator_gl_test']),
    mutant('val-cpu-zblock', 'VAL generator', 'even stride: block depth mean with z00 twice instead of zc (CPU)',
           [edit(VAL_CPU, r'bool valFromDepth\(', '0.25f * (z00 + z10 + z01 + zc)', '0.25f * (z00 + z10 + z01 + z00)')],
           ['gi_cpu_val_generator_gl_test']),
    mutant('val-ref-cosalpha', 'VAL generator', 'VAL area without cos(alpha) (double reference)',
           [edit('gi/reference/src/ValGeneratorReference.cpp', r'generateValsReference\(const cv::Mat',
                 'footprint * ray.z / cosTheta', 'footprint / cosTheta')], ['gi_val_generator_test']),
]

SAMPLER = 'gi/common/src/SparsePointSampler.cpp'
SPARSE_POINTS = [
    mutant('sp-fps-compare', 'sparse-point sampler', 'farthest-point update keeps the larger distance',
           [edit(SAMPLER, r'farthestPoints\(const std::vector<Candidate>', 'if (distances2[i] < minDistance2[j])',
                 'if (distances2[i] > minDistance2[j])')], ['gi_sparse_points_test'], quick=True),
    mutant('sp-area-uniform', 'sparse-point sampler', 'candidates not area-uniform in a triangle (r1 without sqrt)',
           [edit(SAMPLER, r'sampleCandidates\(const TriangleMesh', 'const double r1 = std::sqrt(uniform(random))',
                 'const double r1 = uniform(random)')], ['gi_sparse_points_test']),
    mutant('sp-normal-flip', 'sparse-point sampler', 'candidate normals flipped',
           [edit(SAMPLER, r'sampleCandidates\(const TriangleMesh', 'candidate.normal = glm::normalize(n);',
                 'candidate.normal = -glm::normalize(n);')], ['gi_sparse_points_test']),
    mutant('sp-neighbour-skip', 'sparse-point sampler', 'vertex neighbours off by one (nearest skipped)',
           [edit(SAMPLER, r'SparsePointSet sampleSparsePoints\(', 'indices[std::size_t(std::min(j, int',
                 'indices[std::size_t(std::min(j + 1, int')], ['gi_sparse_points_test']),
    mutant('sp-occluder-r2', 'sparse-point sampler', 'occluder radius = squared distance to the owned vertex',
           [edit(SAMPLER, r'SparsePointSet sampleSparsePoints\(',
                 'radius[neighbours[0]] = std::max(radius[neighbours[0]], std::sqrt(distances2[0]));',
                 'radius[neighbours[0]] = std::max(radius[neighbours[0]], distances2[0]);')],
           ['gi_sparse_points_test', 'gi_truth_gl_test']),
]

BRUTE = 'gi/bruteforce/shaders/bruteforce_gather.frag'
BRUTE_FORCE = [
    mutant('bf-loop', 'brute force', 'last VAL of every chunk skipped (loop bound off by one)',
           [edit(BRUTE, MAIN, 'j < uValCount;', 'j < uValCount - 1;')], ['gi_gather_gl_test:BruteForceGLTest.*'],
           quick=True),
    mutant('bf-diffuse-pi', 'brute force', 'diffuse brute force without 1/pi',
           [edit(BRUTE, MAIN, 'sum *= rhoD / kPi;', 'sum *= rhoD;')],
           ['gi_gather_gl_test:BruteForceGLTest.*', 'gi_near_contact_gl_test']),
    mutant('bf-irradiance-pi', 'brute force', 'eq. 4 irradiance of the brute force without 1/pi (GPU and double)',
           [edit(MATH, r'rvec3 ls_irradiance\(', 'flux * (t.g / kPi * t.cosI)', 'flux * (t.g * t.cosI)')],
           ['gi_near_contact_gl_test']),
    mutant('bf-radiance-pi', 'brute force', 'glossy brute force: rho_d E without 1/pi (GPU and double)',
           [edit(MATH, r'rvec3 ls_bruteForceRadiance\(', 'rhoD * (s.irradiance / kPi)', 'rhoD * s.irradiance')],
           ['gi_near_contact_gl_test', 'gi_gather_gl_test']),
]

RAY_TRACED_TRUTH = [
    mutant('rt-emitted-pi', 'ray-traced truth', 'L_e = flux / area, pi dropped',
           [edit(TRUTH_GL, r'void RayTracedGroundTruth::compute\(', 'glm::dvec3(val.flux) / (pi * area)',
                 'glm::dvec3(val.flux) / area')], ['gi_ground_truth_test'], quick=True),
    mutant('rt-ring-sqrt', 'ray-traced truth', 'disc cells not equal-area (ring radius without sqrt)',
           [edit(TRUTH_GL, r'void RayTracedGroundTruth::compute\(',
                 'radius * std::sqrt((ring + 0.5) / settings.discRings)',
                 'radius * ((ring + 0.5) / settings.discRings)')], ['gi_ground_truth_test']),
    mutant('rt-glossy-k', 'ray-traced truth', 'eq. 5 in the truth: cos^(k+1)',
           [edit(TRUTH_GL, r'void RayTracedGroundTruth::compute\(', 'std::pow(cosGamma, k)',
                 'std::pow(cosGamma, k + 1.0)')],
           ['gi_ground_truth_test']),
    mutant('rt-visibility', 'ray-traced truth', 'shadow ray result inverted',
           [edit(TRUTH_GL, r'void RayTracedGroundTruth::compute\(', 'settings.visibility && occluded(',
                 'settings.visibility && !occluded(')], ['gi_ground_truth_test']),
    mutant('rt-centre-r2', 'ray-traced truth', 'centre mode: point 1/d^2 instead of the disc form factor',
           [edit(TRUTH_GL, r'void RayTracedGroundTruth::compute\(', 'pi * radius2 * cosJ / (radius2 + d2)',
                 'pi * radius2 * cosJ / d2')], ['gi_ground_truth_test']),
]

DIFF = 'gi/differential/src/DifferentialIrradiance.cpp'
DIFFERENTIAL = [
    mutant('diff-w-cos', 'differential irradiance', 'shadowed VAL weight without cos(theta_i)',
           [edit(DIFF, r'void testBlock\(', '* cosI * invPi;', '* (cosI > 0.0f ? 1.0f : 0.0f) * invPi;')],
           ['gi_differential_test'], quick=True),
    mutant('diff-albedo', 'differential irradiance', 'virtual emitters\' flux without their albedo',
           [edit(DIFF, r'void DifferentialIrradiance::Impl::updateEmitters\(',
                 'emitterAlbedo[k] * irradiance * emitterArea[k]',
                 'irradiance * emitterArea[k]')], ['gi_differential_test']),
    mutant('diff-point-r', 'differential irradiance', 'point light irradiance 1/d instead of 1/d^2',
           [edit(DIFF, r'glm::dvec3 lightIrradiance\(', '(cosTheta / d2)', '(cosTheta / std::sqrt(d2))')],
           ['gi_differential_test']),
]

VOLUMES_COMMON = 'gi/volumes/shaders/volumes_common.glsl'
VOLUMES_REF = 'gi/reference/src/ImperfectVolumesReference.cpp'
VOLUMES = [
    mutant('vol-sh-lobe', 'imperfect volumes', 'SH cosine lobe A1 = pi/3 instead of 2 pi/3',
           [edit(VOLUMES_COMMON, r'vec4 shCosineLobe\(', '2.0 * kPi / 3.0', 'kPi / 3.0')], ['gi_volumes_gl_test'],
           quick=True),
    mutant('vol-y00', 'imperfect volumes', 'SH constant Y00 = 0.5 instead of 1/(2 sqrt(pi))',
           [edit(VOLUMES_COMMON, r'vec4 shBasis\(', '0.28209479177', '0.5')], ['gi_volumes_gl_test']),
    mutant('vol-ray-weight', 'imperfect volumes', 'ray weight 2 pi / N (hemisphere) for sphere rays',
           [edit('gi/volumes/shaders/volumes_gather.comp', MAIN, '4.0 * kPi / float(uRayCount)',
                 '2.0 * kPi / float(uRayCount)')], ['gi_volumes_gl_test']),
    mutant('vol-shift-sign', 'imperfect volumes', 'reconstruction point shifted into the surface (sign flip)',
           [edit('gi/volumes/shaders/volumes_irradiance.glsl', r'vec3 reconstructIrradiance\(',
                 'p + 0.5 * uVoxelSize * n', 'p - 0.5 * uVoxelSize * n')], ['gi_volumes_gl_test']),
    mutant('vol-inject-pi', 'imperfect volumes', 'VAL radiance = flux / area (pi dropped)',
           [edit('gi/volumes/shaders/volumes_inject_vals.comp', MAIN, 'val.flux.rgb / (kPi * val.positionArea.w)',
                 'val.flux.rgb / val.positionArea.w')], ['gi_volumes_gl_test']),
    mutant('vol-bounce-pi', 'imperfect volumes', 'second bounce: albedo without 1/pi',
           [edit('gi/volumes/shaders/volumes_bounce.comp', MAIN, 'voxel.albedo.rgb / kPi *', 'voxel.albedo.rgb *')],
           ['gi_volumes_gl_test']),
    mutant('vol-ref-y1', 'imperfect volumes', 'double reference: Y1 = sqrt(3 / (2 pi))',
           [{'file': VOLUMES_REF, 'regex': r'(const double kY1 = std::sqrt\(3\.0 / \()4\.0( \* kPi\)\);)',
             'to': r'\g<1>2.0\g<2>'}], ['gi_volumes_reference_test']),
    mutant('vol-ref-weight', 'imperfect volumes', 'double reference: projection weight 2 pi / N',
           [edit(VOLUMES_REF, r'Sh4 projectSh\(', '4.0 * kPi / double(directions.size())',
                 '2.0 * kPi / double(directions.size())')], ['gi_volumes_reference_test']),
]

PRT_SHADE = 'gi/prt/shaders/prt_shade.frag'
PRT_PRE = 'gi/prt/src/PrtPrecompute.cpp'
PRT = [
    mutant('prt-shade-pi', 'multi-scale PRT', 'exit radiance rho E without 1/pi',
           [edit(PRT_SHADE, MAIN, '.rgb / kPi * max(vIrradiance', '.rgb * max(vIrradiance')],
           ['gi_prt_gl_test', 'gi_prt_small_scale_gl_test'], quick=True),
    mutant('prt-normal-map', 'multi-scale PRT', 'small scale: cos(alpha) instead of (1 + cos(alpha)) / 2',
           [edit(PRT_SHADE, r'float smallScaleOcclusion\(', 'return 0.5 + 0.5 * cosAlpha;', 'return cosAlpha;')],
           ['gi_prt_small_scale_gl_test']),
    mutant('prt-connect-pi', 'multi-scale PRT', 'transfer kernel cos cos / d^2 without 1/pi',
           [edit(PRT_PRE, r'PrtData precomputePrt\(', '/ (double(kPi) * double(d2))', '/ double(d2)')],
           ['gi_prt_precompute_test', 'gi_prt_truth_test']),
    mutant('prt-roulette', 'multi-scale PRT', 'Russian roulette without dividing by the survival probability',
           [edit(PRT_PRE, r'PrtData precomputePrt\(', 'glm::dvec3(hit.albedo) / double(survival)',
                 'glm::dvec3(hit.albedo)')],
           ['gi_prt_precompute_test', 'gi_prt_truth_test']),
    mutant('prt-cosine-dir', 'multi-scale PRT', 'cosine sampling with r = u1 instead of sqrt(u1)',
           [edit(PRT_PRE, r'glm::vec3 cosineDirection\(', 'float(std::sqrt(u1))', 'float(u1)')],
           ['gi_prt_precompute_test', 'gi_prt_truth_test']),
    mutant('prt-runtime-cosp', 'multi-scale PRT',
           'entry irradiance from behind the entry (abs(cos_p), not max(cos_p, 0))',
           [edit('gi/prt/src/PrtRuntime.cpp', r'glm::vec3 valIrradiance\(',
                 'std::max(0.0f, n.x * dx + n.y * dy + n.z * dz)',
                 'std::abs(n.x * dx + n.y * dy + n.z * dz)')],
           ['gi_prt_gl_test', 'gi_prt_gather_test', 'gi_prt_truth_test']),
]

COMPOSITOR_CPP = 'render/src/Compositor.cpp'
COMPOSITOR = [
    mutant('comp-band-centre', 'compositor', 'soft depth band not centred on equal depth',
           [edit(COMPOSITOR_CPP, r'float visibility\(float zVirtual', '(2.0f * band) + 0.5f', '(2.0f * band)')],
           ['render_test'], quick=True),
    mutant('comp-share-swap', 'compositor', 'virtual and real depth swapped in the visibility',
           [edit(COMPOSITOR_CPP, r'float compositeShare\(', 'visibility(zVirtual, zRealRow[u], settings)',
                 'visibility(zRealRow[u], zVirtual, settings)')], ['render_test']),
    mutant('comp-diff-sign', 'compositor', 'differential rendering subtracts the added light',
           [edit(COMPOSITOR_CPP, r'void applyDifferentialInto\(', 'p + gain * albedoOverPi * dE',
                 'p - gain * albedoOverPi * dE')], ['render_test']),
    mutant('comp-albedo-clamp', 'compositor', 'differential rendering: rho/pi clamped at pi instead of 1/pi',
           [edit(COMPOSITOR_CPP, r'void applyDifferentialInto\(', 'std::min(p / (gain * eWithout), 1.0f / pi)',
                 'std::min(p / (gain * eWithout), pi)')], ['render_test']),
]

MUTANTS = (LIGHTSKIN_MATH + GATHER_SHADERS + CPU_KERNELS + SHARED + VAL_GENERATOR + SPARSE_POINTS + BRUTE_FORCE +
           RAY_TRACED_TRUTH + DIFFERENTIAL + VOLUMES + PRT + COMPOSITOR)
