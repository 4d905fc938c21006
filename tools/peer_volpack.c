/* peer_volpack.c: one of make bench's peers. Renders a raw int16 volume (ctlab's phantom,
 * written by build/make_phantom or by the bench) with VolPack, Lacroute's shear-warp library
 * (libvolpack1-dev), in one of the bench's cases, and times it.
 *
 *   build/peer_volpack RAW NX NY NZ CASE WIDTH HEIGHT RUNS OUT.ppm
 *
 * CASE: a (composite, unlit, top view), b (composite, lit, top view), c (composite, unlit,
 * oblique: ctlab's orbit camera at azimuth 30, elevation 20, the bounding sphere filling the
 * image). VolPack has no
 * maximum intensity projection (case d). Spacing 1,1,1; the classic transfer function
 * (README): v < -300 transparent, [-300, 50) skin (1.0, 0.79, 0.6) opacity 0.12, [50, 300)
 * transparent, >= 300 bone white opacity 0.8 (per unit of length).
 * Prints one line:
 *   peer=volpack case=C size=WxH threads=1 precompute_ms=P first_ms=F cold_ms=P+F
 *   warm_ms=M renders=N voxels_kept=K
 * precompute: the 8-bit scalars, the normals and the classification (the run-length encoded
 * copies); first: the first render after it (shade table included); warm: the median of the
 * other RUNS - 1 renders (each one a full vpRenderClassifiedVolume). Exit status 2 with one
 * line on bad input.
 *
 * What VolPack makes us do (../shared/performance.md, checked by tests/peers_test.sh):
 *  - 8-bit scalars: each CT value goes to one byte, 10 CT units per step from -1200, so that
 *    the table's edges (-300, 50, 300) fall on byte edges (the classes are exact).
 *  - Its eye space composites from -z towards +z: the viewer sits on -z. With the identity
 *    the rays run along +k from the crown (k = 0), as ctlab's top view does.
 *  - vpShadeTable shades with the inverse MODEL matrix: MODEL is a pure rotation.
 *  - VP_MAX_RAY_OPACITY defaults to 1 (no early termination): 0.99222, as VTK (255/32767).
 *  - A fully transparent classified volume crashed it: refused before rendering. */
#define _POSIX_C_SOURCE 199309L  /* clock_gettime */
#include <errno.h>
#include <math.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <volpack.h>

#define SCALAR_LOW (-1200)          /* CT value of byte 0 */
#define SCALAR_STEP 10              /* CT units per byte step */
#define SKIN_LOW (-300)             /* the classic table's edges (CT values, half-open) */
#define SKIN_HIGH 50
#define BONE_LOW 300
#define SKIN_OPACITY 0.12           /* per unit of length (voxel spacing 1) */
#define BONE_OPACITY 0.8
#define MAX_RAY_OPACITY 0.99222     /* early termination, as VTK's 1 - 255/32767 */
#define AMBIENT 0.2                 /* case b's shading, as performance.md gives VTK's */
#define DIFFUSE 0.7
#define SPECULAR 0.1
#define SHININESS 10.0
#define AZIMUTH_DEG 30.0            /* case c */
#define ELEVATION_DEG 20.0
#define MAX_SIDE 4096               /* pixels */
#define MAX_RUNS 10000

typedef struct {
    unsigned short normal;  /* VolPack's encoded normal (vpVolumeNormals) */
    unsigned char scalar;   /* the CT value as a byte (see SCALAR_LOW) */
    unsigned char unused;
} Voxel;

enum { normal_field = 0, scalar_field = 1, material_count = 2 /* skin, bone */ };

static float opacity_table[VP_SCALAR_MAX + 1];
static float weight_table[VP_SCALAR_MAX + 1][material_count];
static float color_table[VP_NORM_MAX + 1][material_count][3];
static const double skin_rgb[3] = {1.0, 0.79, 0.6};
static const double bone_rgb[3] = {1.0, 1.0, 1.0};

static void fail(const char* what, const char* detail) {
    fprintf(stderr, "peer_volpack: %s%s%s\n", what, detail ? ": " : "", detail ? detail : "");
    exit(2);
}

static void check(vpContext* vpc, vpResult result, const char* what) {
    if (result != VP_OK) fail(what, vpGetErrorString(vpGetError(vpc)));
}

static double now_ms(void) {
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return t.tv_sec * 1e3 + t.tv_nsec / 1e6;
}

static int compare_doubles(const void* a, const void* b) {
    const double x = *(const double*)a, y = *(const double*)b;
    return (x > y) - (x < y);
}

static long parse_long(const char* name, const char* text, long low, long high) {
    char* end = NULL;
    errno = 0;
    const long value = strtol(text, &end, 10);
    if (errno != 0 || end == text || *end != '\0' || value < low || value > high) {
        fprintf(stderr, "peer_volpack: %s: expected a whole number %ld..%ld, got '%s'\n",
                name, low, high, text);
        exit(2);
    }
    return value;
}

/* The CT value as a byte: 10 units per step from SCALAR_LOW, clamped. */
static unsigned char scalar_of(int value) {
    const int byte = (value - SCALAR_LOW) / SCALAR_STEP;
    if (value < SCALAR_LOW || byte < 0) return 0;
    return (unsigned char)(byte > VP_SCALAR_MAX ? VP_SCALAR_MAX : byte);
}

/* The classic table as VolPack's tables: opacity per byte, and per byte the weight of each
 * material (skin, bone) in the colour. */
static void classic_tables(void) {
    for (int byte = 0; byte <= VP_SCALAR_MAX; ++byte) {
        const int value = SCALAR_LOW + byte * SCALAR_STEP;  /* the byte's lowest CT value */
        const int skin = value >= SKIN_LOW && value < SKIN_HIGH;
        const int bone = value >= BONE_LOW;
        opacity_table[byte] = skin ? SKIN_OPACITY : bone ? BONE_OPACITY : 0.0f;
        weight_table[byte][0] = skin ? 1.0f : 0.0f;
        weight_table[byte][1] = bone ? 1.0f : 0.0f;
    }
}

/* MODEL for ctlab's orbit camera (steps/10: azimuth 0 faces the face, looking along +j;
 * 90 looks along +i; elevation 90 looks down from the crown, along +k; the image's up is the
 * crown, -k). Eye space: rays along +z (VolPack composites from -z), image rows down +y,
 * columns right +x; so the rows of the rotation are right, down and forward in object space:
 * a pure rotation (right = down x forward), as vpShadeTable needs. */
static void camera_rotation(double azimuth_deg, double elevation_deg, vpMatrix4 model) {
    const double pi = 3.14159265358979323846;
    const double az = azimuth_deg * pi / 180, el = elevation_deg * pi / 180;
    const double forward[3] = {sin(az) * cos(el), cos(az) * cos(el), sin(el)};
    /* down: +k without its part along forward */
    double down[3] = {-forward[2] * forward[0], -forward[2] * forward[1],
                      1 - forward[2] * forward[2]};
    const double length = sqrt(down[0] * down[0] + down[1] * down[1] + down[2] * down[2]);
    for (int n = 0; n < 3; ++n) down[n] /= length;
    const double right[3] = {down[1] * forward[2] - down[2] * forward[1],
                             down[2] * forward[0] - down[0] * forward[2],
                             down[0] * forward[1] - down[1] * forward[0]};
    for (int row = 0; row < 4; ++row) {
        for (int col = 0; col < 4; ++col) model[row][col] = row == col;
    }
    for (int col = 0; col < 3; ++col) {
        model[0][col] = right[col];
        model[1][col] = down[col];
        model[2][col] = forward[col];
    }
}

static void write_ppm(const char* path, const unsigned char* rgb, int width, int height) {
    FILE* file = fopen(path, "wb");
    if (!file) fail("cannot write the picture", path);
    fprintf(file, "P6\n%d %d\n255\n", width, height);
    const size_t bytes = (size_t)width * height * 3;
    const int written = fwrite(rgb, 1, bytes, file) == bytes;
    if (fclose(file) != 0 || !written) fail("cannot write the picture", path);
}

int main(int argc, char** argv) {
    if (argc == 2 && strcmp(argv[1], "--help") == 0) {
        printf("usage: peer_volpack RAW NX NY NZ CASE(a|b|c) WIDTH HEIGHT RUNS OUT.ppm\n");
        return 0;
    }
    if (argc != 10) fail("usage: peer_volpack RAW NX NY NZ CASE(a|b|c) WIDTH HEIGHT RUNS "
                         "OUT.ppm", NULL);
    const int nx = (int)parse_long("NX", argv[2], 2, VP_MAX_VOLUME_DIM);
    const int ny = (int)parse_long("NY", argv[3], 2, VP_MAX_VOLUME_DIM);
    const int nz = (int)parse_long("NZ", argv[4], 2, VP_MAX_VOLUME_DIM);
    const char* which = argv[5];
    if (strcmp(which, "a") != 0 && strcmp(which, "b") != 0 && strcmp(which, "c") != 0) {
        fail("CASE: expected a, b or c (VolPack has no maximum intensity, case d)", which);
    }
    const int lit = which[0] == 'b', oblique = which[0] == 'c';
    const int width = (int)parse_long("WIDTH", argv[6], 1, MAX_SIDE);
    const int height = (int)parse_long("HEIGHT", argv[7], 1, MAX_SIDE);
    const int runs = (int)parse_long("RUNS", argv[8], 1, MAX_RUNS);
    const char* out_path = argv[9];

    /* Volume: int16 little-endian, i fastest. */
    const size_t count = (size_t)nx * ny * nz;
    unsigned char* bytes = malloc(count * 2);
    unsigned char* scalars = malloc(count);
    Voxel* voxels = calloc(count, sizeof(Voxel));
    unsigned char* image = calloc((size_t)width * height, 3);
    double* times = malloc(sizeof(double) * runs);
    if (!bytes || !scalars || !voxels || !image || !times) fail("out of memory", NULL);
    FILE* file = fopen(argv[1], "rb");
    if (!file) fail("cannot open the volume", argv[1]);
    const size_t got = fread(bytes, 1, count * 2, file);
    const int extra = fgetc(file) != EOF;
    fclose(file);
    if (got != count * 2 || extra) fail("the volume's size is not NX*NY*NZ*2 bytes", argv[1]);

    vpContext* vpc = vpCreateContext();
    check(vpc, vpSetVolumeSize(vpc, nx, ny, nz), "vpSetVolumeSize");
    check(vpc, vpSetVoxelSize(vpc, sizeof(Voxel), 2, 2, 1), "vpSetVoxelSize");
    check(vpc, vpSetVoxelField(vpc, normal_field, sizeof(unsigned short),
                               (int)offsetof(Voxel, normal), VP_NORM_MAX), "vpSetVoxelField");
    check(vpc, vpSetVoxelField(vpc, scalar_field, sizeof(unsigned char),
                               (int)offsetof(Voxel, scalar), VP_SCALAR_MAX), "vpSetVoxelField");
    check(vpc, vpSetRawVoxels(vpc, voxels, (int)(count * sizeof(Voxel)), sizeof(Voxel),
                              nx * (int)sizeof(Voxel), nx * ny * (int)sizeof(Voxel)),
          "vpSetRawVoxels");
    classic_tables();
    check(vpc, vpSetClassifierTable(vpc, 0, scalar_field, opacity_table, sizeof opacity_table),
          "vpSetClassifierTable");
    check(vpc, vpSetd(vpc, VP_MIN_VOXEL_OPACITY, 0.001), "VP_MIN_VOXEL_OPACITY");
    check(vpc, vpSetd(vpc, VP_MAX_RAY_OPACITY, MAX_RAY_OPACITY), "VP_MAX_RAY_OPACITY");
    check(vpc, vpSetLookupShader(vpc, 3, material_count, normal_field, &color_table[0][0][0],
                                 sizeof color_table, scalar_field, &weight_table[0][0],
                                 sizeof weight_table), "vpSetLookupShader");

    /* Precomputation: bytes, normals, classification (VolPack's run-length encoded copies). */
    const double precompute_start = now_ms();
    size_t kept = 0;
    for (size_t n = 0; n < count; ++n) {
        const int value = (int16_t)(bytes[2 * n] | bytes[2 * n + 1] << 8);
        scalars[n] = scalar_of(value);
        kept += opacity_table[scalars[n]] > 0;
    }
    if (kept == 0) fail("the classic table leaves every voxel transparent", argv[1]);
    check(vpc, vpVolumeNormals(vpc, scalars, (int)count, scalar_field, VP_SKIP_FIELD,
                               normal_field), "vpVolumeNormals");
    check(vpc, vpClassifyVolume(vpc), "vpClassifyVolume");
    const double precompute_ms = now_ms() - precompute_start;

    /* View. Object space: the volume in a cube of side 1 for its largest axis, centred.
     * MODEL: a pure rotation (case c: camera_rotation); VIEW: identity;
     * PROJECT: the window. Top view: 1 pixel per voxel of the largest axis. */
    const int largest = nx > ny ? (nx > nz ? nx : nz) : (ny > nz ? ny : nz);
    double half_w = 0.5 * width / largest, half_h = 0.5 * height / largest;
    if (oblique) {
        /* The bounding sphere fills the image's shorter side. */
        const double radius = 0.5 * sqrt((double)nx * nx + (double)ny * ny + (double)nz * nz) /
                              largest;
        const double side = width < height ? width : height;
        half_w = radius * width / side;
        half_h = radius * height / side;
    }
    check(vpc, vpCurrentMatrix(vpc, VP_MODEL), "vpCurrentMatrix");
    check(vpc, vpIdentityMatrix(vpc), "vpIdentityMatrix");
    if (oblique) {
        vpMatrix4 model;
        camera_rotation(AZIMUTH_DEG, ELEVATION_DEG, model);
        check(vpc, vpSetMatrix(vpc, model), "vpSetMatrix");
    }
    check(vpc, vpCurrentMatrix(vpc, VP_PROJECT), "vpCurrentMatrix");
    check(vpc, vpIdentityMatrix(vpc), "vpIdentityMatrix");
    check(vpc, vpWindow(vpc, VP_PARALLEL, -half_w, half_w, -half_h, half_h, -1, 1),
          "vpWindow");
    check(vpc, vpSetImage(vpc, image, width, height, width * 3, VP_RGB), "vpSetImage");

    /* Colours: unlit, each material its own colour whatever the normal; lit, VolPack's
     * Phong tables (vpShadeTable) with one light along the view axis (a headlight). */
    if (lit) {
        for (int m = 0; m < material_count; ++m) {
            const double* rgb = m == 0 ? skin_rgb : bone_rgb;
            const int material = VP_MATERIAL0 + m;
            check(vpc, vpSetMaterial(vpc, material, VP_AMBIENT, VP_BOTH_SIDES, AMBIENT * rgb[0],
                                     AMBIENT * rgb[1], AMBIENT * rgb[2]), "vpSetMaterial");
            check(vpc, vpSetMaterial(vpc, material, VP_DIFFUSE, VP_BOTH_SIDES, DIFFUSE * rgb[0],
                                     DIFFUSE * rgb[1], DIFFUSE * rgb[2]), "vpSetMaterial");
            check(vpc, vpSetMaterial(vpc, material, VP_SPECULAR, VP_BOTH_SIDES, SPECULAR,
                                     SPECULAR, SPECULAR), "vpSetMaterial");
            check(vpc, vpSetMaterial(vpc, material, VP_SHINYNESS, VP_BOTH_SIDES, SHININESS, 0,
                                     0), "vpSetMaterial");
        }
        check(vpc, vpSetLight(vpc, VP_LIGHT0, VP_DIRECTION, 0, 0, -1), "vpSetLight");
        check(vpc, vpSetLight(vpc, VP_LIGHT0, VP_COLOR, 1, 1, 1), "vpSetLight");
        check(vpc, vpEnable(vpc, VP_LIGHT0, 1), "vpEnable");
        check(vpc, vpEnable(vpc, VP_LIGHT_BOTH_SIDES, 1), "vpEnable");
    } else {
        for (int n = 0; n <= VP_NORM_MAX; ++n) {
            for (int c = 0; c < 3; ++c) {
                color_table[n][0][c] = (float)(255 * skin_rgb[c]);
                color_table[n][1][c] = (float)(255 * bone_rgb[c]);
            }
        }
    }

    /* Renders: the first (with the shade table), then RUNS - 1 warm ones. */
    double first_ms = 0;
    for (int run = 0; run < runs; ++run) {
        const double start = now_ms();
        if (lit) check(vpc, vpShadeTable(vpc), "vpShadeTable");
        check(vpc, vpRenderClassifiedVolume(vpc), "vpRenderClassifiedVolume");
        times[run] = now_ms() - start;
        if (run == 0) first_ms = times[0];
    }
    double warm_ms = first_ms;
    if (runs > 1) {
        qsort(times + 1, runs - 1, sizeof(double), compare_doubles);
        const int n = runs - 1;
        warm_ms = n % 2 ? times[1 + n / 2] : (times[n / 2] + times[1 + n / 2]) / 2;
    }
    /* VolPack's first image row is eye-space y's smallest: the top row, as ctlab's. */
    write_ppm(out_path, image, width, height);
    printf("peer=volpack case=%s size=%dx%d threads=1 precompute_ms=%.3f first_ms=%.3f "
           "cold_ms=%.3f warm_ms=%.3f renders=%d voxels_kept=%zu\n",
           which, width, height, precompute_ms, first_ms, precompute_ms + first_ms, warm_ms,
           runs, kept);
    vpDestroyContext(vpc);
    free(times);
    free(image);
    free(voxels);
    free(scalars);
    free(bytes);
    return 0;
}
