/* pipeline_stats: compile one graphics pipeline (a vertex and a fragment SPIR-V module) on
 * the first Vulkan device and print the driver's per-executable statistics
 * (VK_KHR_pipeline_executable_properties), one "stage<TAB>statistic<TAB>value" line each.
 *
 * Meant for Mesa RADV's null device (RADV_FORCE_FAMILY=navi21 and so on), which compiles
 * pipelines without a GPU.  The descriptor set layouts come from the fragment module itself:
 * a small SPIR-V reflection below reads each resource variable's set, binding and type, so
 * the caller passes nothing but the two files.
 *
 * Build: cc -O1 -o pipeline_stats pipeline_stats.c -lvulkan
 * Exit status: 0 printed; 2 bad input or a Vulkan call failed (the call is named). */
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <vulkan/vulkan.h>

#define MAX_SETS 4
#define MAX_BINDINGS 32

static void fail(const char *what, VkResult r) {
    fprintf(stderr, "pipeline_stats: %s returned VkResult %d\n", what, (int)r);
    exit(2);
}
#define VK(call) do { VkResult r_ = (call); if (r_ != VK_SUCCESS) fail(#call, r_); } while (0)

typedef struct { uint32_t *words; size_t count; } Module;

static Module load(const char *path) {
    FILE *f = fopen(path, "rb");
    if (!f) { perror(path); exit(2); }
    fseek(f, 0, SEEK_END);
    long n = ftell(f);
    rewind(f);
    Module m = {malloc(n), (size_t)n / 4};
    if (n < 20 || n % 4 || fread(m.words, 1, n, f) != (size_t)n || m.words[0] != 0x07230203) {
        fprintf(stderr, "pipeline_stats: %s is not a SPIR-V module\n", path);
        exit(2);
    }
    fclose(f);
    return m;
}

/* ---- reflection: what each id is, as far as descriptor layouts need ---------------------- */
enum { OP_DECORATE = 71, OP_TYPE_IMAGE = 25, OP_TYPE_SAMPLER = 26, OP_TYPE_SAMPLED_IMAGE = 27,
       OP_TYPE_ARRAY = 28, OP_TYPE_RUNTIME_ARRAY = 29, OP_TYPE_STRUCT = 30, OP_TYPE_POINTER = 32,
       OP_CONSTANT = 43, OP_VARIABLE = 59 };
enum { DEC_BLOCK = 2, DEC_BUFFER_BLOCK = 3, DEC_BINDING = 33, DEC_SET = 34 };
enum { SC_UNIFORM_CONSTANT = 0, SC_UNIFORM = 2, SC_PUSH_CONSTANT = 9, SC_STORAGE_BUFFER = 12 };

typedef struct {
    uint16_t op;
    uint32_t a, b, c;          /* operands after the result id, by opcode (see reflect) */
    int32_t set, binding;      /* -1 when undecorated */
    uint8_t buffer_block;
} Id;

static VkDescriptorType descriptor_of(const Id *ids, uint32_t type, uint32_t storage,
                                      uint32_t *count) {
    *count = 1;
    while (ids[type].op == OP_TYPE_ARRAY || ids[type].op == OP_TYPE_RUNTIME_ARRAY) {
        if (ids[type].op == OP_TYPE_ARRAY) *count *= ids[ids[type].b].a;
        type = ids[type].a;
    }
    if (storage == SC_STORAGE_BUFFER) return VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
    if (storage == SC_UNIFORM)
        return ids[type].buffer_block ? VK_DESCRIPTOR_TYPE_STORAGE_BUFFER
                                      : VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER;
    switch (ids[type].op) {
    case OP_TYPE_SAMPLED_IMAGE: return VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER;
    case OP_TYPE_SAMPLER: return VK_DESCRIPTOR_TYPE_SAMPLER;
    case OP_TYPE_IMAGE: {
        int buffer = ids[type].b == 5, storage_image = ids[type].c == 2;
        if (buffer) return storage_image ? VK_DESCRIPTOR_TYPE_STORAGE_TEXEL_BUFFER
                                         : VK_DESCRIPTOR_TYPE_UNIFORM_TEXEL_BUFFER;
        return storage_image ? VK_DESCRIPTOR_TYPE_STORAGE_IMAGE : VK_DESCRIPTOR_TYPE_SAMPLED_IMAGE;
    }
    default:
        fprintf(stderr, "pipeline_stats: a resource of SPIR-V type opcode %u has no descriptor "
                "kind here\n", ids[type].op);
        exit(2);
    }
}

typedef struct {
    VkDescriptorSetLayoutBinding bindings[MAX_SETS][MAX_BINDINGS];
    uint32_t counts[MAX_SETS], sets;
    uint32_t push_constants;
} Layout;

static Layout reflect(Module m) {
    uint32_t bound = m.words[3];
    Id *ids = calloc(bound, sizeof *ids);
    for (uint32_t i = 0; i < bound; i++) ids[i].set = ids[i].binding = -1;
    Layout out = {0};
    for (int pass = 0; pass < 2; pass++) {      /* types and decorations, then variables */
        for (size_t at = 5; at < m.count;) {
            uint32_t *w = m.words + at, n = w[0] >> 16, op = w[0] & 0xffff;
            if (n == 0 || at + n > m.count) { fprintf(stderr, "pipeline_stats: truncated SPIR-V\n"); exit(2); }
            at += n;
            if (pass == 0 && op == OP_DECORATE && n >= 3 && w[1] < bound) {
                if (w[2] == DEC_SET && n >= 4) ids[w[1]].set = (int32_t)w[3];
                if (w[2] == DEC_BINDING && n >= 4) ids[w[1]].binding = (int32_t)w[3];
                if (w[2] == DEC_BUFFER_BLOCK) ids[w[1]].buffer_block = 1;
            } else if (pass == 0 && n >= 2 && w[1] < bound &&
                       ((op >= OP_TYPE_IMAGE && op <= OP_TYPE_STRUCT) || op == OP_TYPE_POINTER)) {
                Id *d = &ids[w[1]];
                d->op = (uint16_t)op;
                d->a = n > 2 ? w[2] : 0; d->b = n > 3 ? w[3] : 0;
                d->c = op == OP_TYPE_IMAGE && n > 7 ? w[7] : (n > 4 ? w[4] : 0);
            } else if (pass == 0 && op == OP_CONSTANT && n >= 4 && w[2] < bound) {
                ids[w[2]].op = (uint16_t)op; ids[w[2]].a = w[3];
            } else if (pass == 1 && op == OP_VARIABLE && n >= 4 && w[2] < bound) {
                uint32_t var = w[2], storage = w[3], pointee = ids[w[1]].b;
                if (storage == SC_PUSH_CONSTANT) { out.push_constants = 128; continue; }
                if (storage != SC_UNIFORM_CONSTANT && storage != SC_UNIFORM &&
                    storage != SC_STORAGE_BUFFER) continue;
                int32_t set = ids[var].set < 0 ? 0 : ids[var].set, binding = ids[var].binding;
                if (binding < 0 || set >= MAX_SETS || out.counts[set] == MAX_BINDINGS) {
                    fprintf(stderr, "pipeline_stats: resource id %u has set %d binding %d; compile "
                            "with glslangValidator --amb so every resource has a binding\n",
                            var, set, binding);
                    exit(2);
                }
                VkDescriptorSetLayoutBinding *b = &out.bindings[set][out.counts[set]++];
                memset(b, 0, sizeof *b);
                b->binding = (uint32_t)binding;
                b->descriptorType = descriptor_of(ids, pointee, storage, &b->descriptorCount);
                b->stageFlags = VK_SHADER_STAGE_ALL_GRAPHICS;
                if ((uint32_t)set + 1 > out.sets) out.sets = (uint32_t)set + 1;
            }
        }
    }
    free(ids);
    return out;
}

/* ---- the device and the pipeline --------------------------------------------------------- */
static VkDevice open_device(void) {
    VkApplicationInfo app = {.sType = VK_STRUCTURE_TYPE_APPLICATION_INFO,
                             .pApplicationName = "blockhash pipeline_stats",
                             .apiVersion = VK_API_VERSION_1_2};
    VkInstanceCreateInfo ici = {.sType = VK_STRUCTURE_TYPE_INSTANCE_CREATE_INFO,
                                .pApplicationInfo = &app};
    VkInstance instance;
    VK(vkCreateInstance(&ici, NULL, &instance));
    uint32_t n = 1;
    VkPhysicalDevice pd;
    VkResult r = vkEnumeratePhysicalDevices(instance, &n, &pd);
    if ((r != VK_SUCCESS && r != VK_INCOMPLETE) || n == 0) {
        fprintf(stderr, "pipeline_stats: no Vulkan device; for RADV's null device set "
                "RADV_FORCE_FAMILY (e.g. navi21) and VK_ICD_FILENAMES to radeon_icd\n");
        exit(2);
    }
    VkPhysicalDeviceProperties props;
    vkGetPhysicalDeviceProperties(pd, &props);
    printf("device\tname\t%s\n", props.deviceName);
    printf("device\tdriver\t%u.%u.%u\n", VK_VERSION_MAJOR(props.driverVersion),
           VK_VERSION_MINOR(props.driverVersion), VK_VERSION_PATCH(props.driverVersion));

    VkPhysicalDevicePipelineExecutablePropertiesFeaturesKHR exe = {
        .sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_PIPELINE_EXECUTABLE_PROPERTIES_FEATURES_KHR,
        .pipelineExecutableInfo = VK_TRUE};
    VkPhysicalDeviceFeatures2 features = {.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2,
                                          .pNext = &exe};
    vkGetPhysicalDeviceFeatures(pd, &features.features); /* what GLSL 4.5 may use: all of it */
    features.features.robustBufferAccess = VK_FALSE;      /* a GL context's default */
    float priority = 1.0f;
    VkDeviceQueueCreateInfo queue = {.sType = VK_STRUCTURE_TYPE_DEVICE_QUEUE_CREATE_INFO,
                                     .queueFamilyIndex = 0, .queueCount = 1,
                                     .pQueuePriorities = &priority};
    const char *ext = VK_KHR_PIPELINE_EXECUTABLE_PROPERTIES_EXTENSION_NAME;
    VkDeviceCreateInfo dci = {.sType = VK_STRUCTURE_TYPE_DEVICE_CREATE_INFO, .pNext = &features,
                              .queueCreateInfoCount = 1, .pQueueCreateInfos = &queue,
                              .enabledExtensionCount = 1, .ppEnabledExtensionNames = &ext};
    VkDevice device;
    VK(vkCreateDevice(pd, &dci, NULL, &device));
    return device;
}

static VkShaderModule shader_module(VkDevice device, Module m) {
    VkShaderModuleCreateInfo info = {.sType = VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO,
                                     .codeSize = m.count * 4, .pCode = m.words};
    VkShaderModule out;
    VK(vkCreateShaderModule(device, &info, NULL, &out));
    return out;
}

static VkPipelineLayout pipeline_layout(VkDevice device, const Layout *l) {
    VkDescriptorSetLayout sets[MAX_SETS];
    for (uint32_t s = 0; s < l->sets; s++) {
        VkDescriptorSetLayoutCreateInfo info = {
            .sType = VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO,
            .bindingCount = l->counts[s], .pBindings = l->bindings[s]};
        VK(vkCreateDescriptorSetLayout(device, &info, NULL, &sets[s]));
    }
    VkPushConstantRange push = {VK_SHADER_STAGE_ALL_GRAPHICS, 0, l->push_constants};
    VkPipelineLayoutCreateInfo info = {.sType = VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO,
                                       .setLayoutCount = l->sets, .pSetLayouts = sets,
                                       .pushConstantRangeCount = l->push_constants ? 1 : 0,
                                       .pPushConstantRanges = &push};
    VkPipelineLayout out;
    VK(vkCreatePipelineLayout(device, &info, NULL, &out));
    return out;
}

static VkRenderPass render_pass(VkDevice device) {
    VkAttachmentDescription color = {
        .format = VK_FORMAT_R32G32B32A32_SFLOAT, .samples = VK_SAMPLE_COUNT_1_BIT,
        .loadOp = VK_ATTACHMENT_LOAD_OP_DONT_CARE, .storeOp = VK_ATTACHMENT_STORE_OP_STORE,
        .stencilLoadOp = VK_ATTACHMENT_LOAD_OP_DONT_CARE,
        .stencilStoreOp = VK_ATTACHMENT_STORE_OP_DONT_CARE,
        .initialLayout = VK_IMAGE_LAYOUT_UNDEFINED,
        .finalLayout = VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL};
    VkAttachmentReference ref = {0, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL};
    VkSubpassDescription subpass = {.pipelineBindPoint = VK_PIPELINE_BIND_POINT_GRAPHICS,
                                    .colorAttachmentCount = 1, .pColorAttachments = &ref};
    VkRenderPassCreateInfo info = {.sType = VK_STRUCTURE_TYPE_RENDER_PASS_CREATE_INFO,
                                   .attachmentCount = 1, .pAttachments = &color,
                                   .subpassCount = 1, .pSubpasses = &subpass};
    VkRenderPass out;
    VK(vkCreateRenderPass(device, &info, NULL, &out));
    return out;
}

static VkPipeline pipeline(VkDevice device, VkShaderModule vs, VkShaderModule fs,
                           VkPipelineLayout layout, VkRenderPass pass) {
    VkPipelineShaderStageCreateInfo stages[2] = {
        {.sType = VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO,
         .stage = VK_SHADER_STAGE_VERTEX_BIT, .module = vs, .pName = "main"},
        {.sType = VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO,
         .stage = VK_SHADER_STAGE_FRAGMENT_BIT, .module = fs, .pName = "main"}};
    VkPipelineVertexInputStateCreateInfo input = {
        .sType = VK_STRUCTURE_TYPE_PIPELINE_VERTEX_INPUT_STATE_CREATE_INFO};
    VkPipelineInputAssemblyStateCreateInfo assembly = {
        .sType = VK_STRUCTURE_TYPE_PIPELINE_INPUT_ASSEMBLY_STATE_CREATE_INFO,
        .topology = VK_PRIMITIVE_TOPOLOGY_TRIANGLE_LIST};
    VkViewport viewport = {0, 0, 512, 512, 0, 1};
    VkRect2D scissor = {{0, 0}, {512, 512}};
    VkPipelineViewportStateCreateInfo view = {
        .sType = VK_STRUCTURE_TYPE_PIPELINE_VIEWPORT_STATE_CREATE_INFO,
        .viewportCount = 1, .pViewports = &viewport, .scissorCount = 1, .pScissors = &scissor};
    VkPipelineRasterizationStateCreateInfo raster = {
        .sType = VK_STRUCTURE_TYPE_PIPELINE_RASTERIZATION_STATE_CREATE_INFO,
        .polygonMode = VK_POLYGON_MODE_FILL, .cullMode = VK_CULL_MODE_NONE, .lineWidth = 1};
    VkPipelineMultisampleStateCreateInfo samples = {
        .sType = VK_STRUCTURE_TYPE_PIPELINE_MULTISAMPLE_STATE_CREATE_INFO,
        .rasterizationSamples = VK_SAMPLE_COUNT_1_BIT};
    VkPipelineColorBlendAttachmentState write = {.colorWriteMask = 0xf};
    VkPipelineColorBlendStateCreateInfo blend = {
        .sType = VK_STRUCTURE_TYPE_PIPELINE_COLOR_BLEND_STATE_CREATE_INFO,
        .attachmentCount = 1, .pAttachments = &write};
    VkGraphicsPipelineCreateInfo info = {
        .sType = VK_STRUCTURE_TYPE_GRAPHICS_PIPELINE_CREATE_INFO,
        .flags = VK_PIPELINE_CREATE_CAPTURE_STATISTICS_BIT_KHR,
        .stageCount = 2, .pStages = stages, .pVertexInputState = &input,
        .pInputAssemblyState = &assembly, .pViewportState = &view,
        .pRasterizationState = &raster, .pMultisampleState = &samples,
        .pColorBlendState = &blend, .layout = layout, .renderPass = pass};
    VkPipeline out;
    VK(vkCreateGraphicsPipelines(device, VK_NULL_HANDLE, 1, &info, NULL, &out));
    return out;
}

static void print_statistics(VkDevice device, VkPipeline pipe) {
    PFN_vkGetPipelineExecutablePropertiesKHR properties =
        (PFN_vkGetPipelineExecutablePropertiesKHR)vkGetDeviceProcAddr(
            device, "vkGetPipelineExecutablePropertiesKHR");
    PFN_vkGetPipelineExecutableStatisticsKHR statistics =
        (PFN_vkGetPipelineExecutableStatisticsKHR)vkGetDeviceProcAddr(
            device, "vkGetPipelineExecutableStatisticsKHR");
    if (!properties || !statistics) {
        fprintf(stderr, "pipeline_stats: the device lacks VK_KHR_pipeline_executable_properties\n");
        exit(2);
    }
    VkPipelineInfoKHR which = {.sType = VK_STRUCTURE_TYPE_PIPELINE_INFO_KHR, .pipeline = pipe};
    uint32_t n = 0;
    VK(properties(device, &which, &n, NULL));
    VkPipelineExecutablePropertiesKHR *exes = calloc(n, sizeof *exes);
    for (uint32_t i = 0; i < n; i++)
        exes[i].sType = VK_STRUCTURE_TYPE_PIPELINE_EXECUTABLE_PROPERTIES_KHR;
    VK(properties(device, &which, &n, exes));
    for (uint32_t e = 0; e < n; e++) {
        const char *stage = exes[e].stages & VK_SHADER_STAGE_FRAGMENT_BIT ? "fragment"
                          : exes[e].stages & VK_SHADER_STAGE_VERTEX_BIT ? "vertex" : "other";
        printf("%s\tSubgroup size\t%u\n", stage, exes[e].subgroupSize);
        VkPipelineExecutableInfoKHR exe = {.sType = VK_STRUCTURE_TYPE_PIPELINE_EXECUTABLE_INFO_KHR,
                                           .pipeline = pipe, .executableIndex = e};
        uint32_t m = 0;
        VK(statistics(device, &exe, &m, NULL));
        VkPipelineExecutableStatisticKHR *stats = calloc(m, sizeof *stats);
        for (uint32_t i = 0; i < m; i++)
            stats[i].sType = VK_STRUCTURE_TYPE_PIPELINE_EXECUTABLE_STATISTIC_KHR;
        VK(statistics(device, &exe, &m, stats));
        for (uint32_t i = 0; i < m; i++) {
            const VkPipelineExecutableStatisticKHR *s = &stats[i];
            printf("%s\t%s\t", stage, s->name);
            if (s->format == VK_PIPELINE_EXECUTABLE_STATISTIC_FORMAT_BOOL32_KHR)
                printf("%u\n", s->value.b32);
            else if (s->format == VK_PIPELINE_EXECUTABLE_STATISTIC_FORMAT_INT64_KHR)
                printf("%lld\n", (long long)s->value.i64);
            else if (s->format == VK_PIPELINE_EXECUTABLE_STATISTIC_FORMAT_UINT64_KHR)
                printf("%llu\n", (unsigned long long)s->value.u64);
            else
                printf("%g\n", s->value.f64);
        }
        free(stats);
    }
    free(exes);
}

int main(int argc, char **argv) {
    if (argc != 3) {
        fprintf(stderr, "usage: pipeline_stats VERTEX.spv FRAGMENT.spv\n");
        return 2;
    }
    Module vs = load(argv[1]), fs = load(argv[2]);
    Layout layout = reflect(fs);
    VkDevice device = open_device();
    VkPipeline pipe = pipeline(device, shader_module(device, vs), shader_module(device, fs),
                               pipeline_layout(device, &layout), render_pass(device));
    print_statistics(device, pipe);
    return 0;
}
