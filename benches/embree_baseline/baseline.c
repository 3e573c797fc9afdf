/* Embree's own single-thread throughput on the benchmark sphere, for comparison with the
 * safe Rust layer (examples/embree_wrapper_bench.rs shoots exactly the same rays).
 *
 *   cc -O2 baseline.c -lembree3 -lm -o baseline && ./baseline [stacks slices size runs passes]
 *   ./baseline --obj sphere.obj [stacks slices]   writes the sphere as an OBJ (for Embree's viewer)
 *
 * Geometry: a UV sphere, centre (0,0,0), radius 1, `stacks` latitude bands and `slices`
 * longitude segments: 2 + slices*(stacks-1) vertices (north pole, the rings from north to
 * south, south pole) and 2*slices*(stacks-1) triangles; default 160 x 318 = 101,124 triangles.
 * Camera: pinhole at (0,0,-3) looking at the origin (+z), up +y, film x along +x,
 * vertical field of view 40 degrees, size x size pixels (default 1024), one ray through each
 * pixel centre. The rays are generated into a buffer before timing.
 * Single rays: rtcIntersect1 per pixel in row order. Packets: rtcIntersect4 on 2x2 pixel
 * quads in row order, RTC_INTERSECT_CONTEXT_FLAG_COHERENT. Each run traces the whole image
 * `passes` times (default 3); single and packet runs alternate, `runs` (default 5) of each,
 * and the median rate of each is printed. One thread, FTZ/DAZ set.
 */
#include <embree3/rtcore.h>
#include <math.h>
#include <pmmintrin.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <xmmintrin.h>

typedef struct { float org[3], dir[3], tnear, tfar; } Ray;

static double now(void) {
  struct timespec ts;
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return ts.tv_sec + 1e-9 * ts.tv_nsec;
}

static void error_handler(void* user, enum RTCError code, const char* msg) {
  (void)user;
  fprintf(stderr, "Embree error %d: %s\n", (int)code, msg ? msg : "");
  exit(1);
}

static int cmp_double(const void* a, const void* b) {
  double x = *(const double*)a, y = *(const double*)b;
  return (x > y) - (x < y);
}

/* Fills v (3 floats per vertex) and t (3 indices per triangle) with the UV sphere. */
static void sphere_mesh(unsigned stacks, unsigned slices, float* v, unsigned* t) {
  unsigned nv = 2 + slices * (stacks - 1), nt = 2 * slices * (stacks - 1);
  unsigned k = 0;
  v[k++] = 0.0f; v[k++] = 1.0f; v[k++] = 0.0f;
  for (unsigned i = 1; i < stacks; i++) {
    double theta = M_PI * i / stacks;
    for (unsigned j = 0; j < slices; j++) {
      double phi = 2.0 * M_PI * j / slices;
      v[k++] = (float)(sin(theta) * cos(phi));
      v[k++] = (float)cos(theta);
      v[k++] = (float)(sin(theta) * sin(phi));
    }
  }
  v[k++] = 0.0f; v[k++] = -1.0f; v[k++] = 0.0f;
  unsigned south = nv - 1, n = 0;
#define RING(i, j) (1 + ((i) - 1) * slices + (j) % slices)
#define TRI(a, b, c) do { t[n++] = (a); t[n++] = (b); t[n++] = (c); } while (0)
  for (unsigned j = 0; j < slices; j++) {
    TRI(0, RING(1, j + 1), RING(1, j));
    TRI(south, RING(stacks - 1, j), RING(stacks - 1, j + 1));
  }
  for (unsigned i = 1; i + 1 < stacks; i++)
    for (unsigned j = 0; j < slices; j++) {
      unsigned a = RING(i, j), b = RING(i, j + 1), c = RING(i + 1, j), d = RING(i + 1, j + 1);
      TRI(a, b, d);
      TRI(a, d, c);
    }
  if (n != 3 * nt || k != 3 * nv) { fprintf(stderr, "sphere size mismatch\n"); exit(1); }
}

static RTCScene uv_sphere(RTCDevice device, unsigned stacks, unsigned slices) {
  unsigned nv = 2 + slices * (stacks - 1), nt = 2 * slices * (stacks - 1);
  RTCGeometry g = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_TRIANGLE);
  float* v = rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 12, nv);
  unsigned* t = rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 12, nt);
  sphere_mesh(stacks, slices, v, t);
  rtcCommitGeometry(g);
  RTCScene scene = rtcNewScene(device);
  rtcAttachGeometry(scene, g);
  rtcReleaseGeometry(g);
  rtcCommitScene(scene);
  return scene;
}

static void camera_rays(Ray* rays, unsigned w, unsigned h) {
  const float tan_half = 0.36397023426620234f; /* tan(20 degrees) */
  const float aspect = (float)w / (float)h;
  for (unsigned y = 0; y < h; y++)
    for (unsigned x = 0; x < w; x++) {
      float sx = (2.0f * ((float)x + 0.5f) / (float)w - 1.0f) * tan_half * aspect;
      float sy = (1.0f - 2.0f * ((float)y + 0.5f) / (float)h) * tan_half;
      float sz = 1.0f;
      float inv = 1.0f / sqrtf(sx * sx + sy * sy + sz * sz);
      Ray* r = &rays[(size_t)y * w + x];
      r->org[0] = 0.0f; r->org[1] = 0.0f; r->org[2] = -3.0f;
      r->dir[0] = sx * inv; r->dir[1] = sy * inv; r->dir[2] = sz * inv;
      r->tnear = 0.0f; r->tfar = INFINITY;
    }
}

static unsigned long single_pass(RTCScene scene, const Ray* rays, size_t n) {
  struct RTCIntersectContext ctx;
  rtcInitIntersectContext(&ctx);
  unsigned long hits = 0;
  for (size_t i = 0; i < n; i++) {
    struct RTCRayHit rh;
    const Ray* r = &rays[i];
    rh.ray.org_x = r->org[0]; rh.ray.org_y = r->org[1]; rh.ray.org_z = r->org[2];
    rh.ray.dir_x = r->dir[0]; rh.ray.dir_y = r->dir[1]; rh.ray.dir_z = r->dir[2];
    rh.ray.tnear = r->tnear; rh.ray.tfar = r->tfar;
    rh.ray.time = 0.0f; rh.ray.mask = 0xffffffffu; rh.ray.id = 0; rh.ray.flags = 0;
    rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
    rtcIntersect1(scene, &ctx, &rh);
    hits += rh.hit.geomID != RTC_INVALID_GEOMETRY_ID;
  }
  return hits;
}

static unsigned long packet_pass(RTCScene scene, const Ray* rays, unsigned w, unsigned h) {
  struct RTCIntersectContext ctx;
  rtcInitIntersectContext(&ctx);
  ctx.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
  unsigned long hits = 0;
  RTC_ALIGN(16) int valid[4];
  RTC_ALIGN(16) struct RTCRayHit4 p;
  for (unsigned y = 0; y < h; y += 2)
    for (unsigned x = 0; x < w; x += 2) {
      for (int k = 0; k < 4; k++) {
        unsigned px = x + (k & 1), py = y + (k >> 1);
        valid[k] = px < w && py < h ? -1 : 0;
        const Ray* r = &rays[(size_t)(py < h ? py : h - 1) * w + (px < w ? px : w - 1)];
        p.ray.org_x[k] = r->org[0]; p.ray.org_y[k] = r->org[1]; p.ray.org_z[k] = r->org[2];
        p.ray.dir_x[k] = r->dir[0]; p.ray.dir_y[k] = r->dir[1]; p.ray.dir_z[k] = r->dir[2];
        p.ray.tnear[k] = r->tnear; p.ray.tfar[k] = r->tfar;
        p.ray.time[k] = 0.0f; p.ray.mask[k] = 0xffffffffu; p.ray.id[k] = k; p.ray.flags[k] = 0;
        p.hit.geomID[k] = RTC_INVALID_GEOMETRY_ID;
      }
      rtcIntersect4(valid, scene, &ctx, &p);
      for (int k = 0; k < 4; k++) hits += valid[k] && p.hit.geomID[k] != RTC_INVALID_GEOMETRY_ID;
    }
  return hits;
}

static int write_obj(const char* path, unsigned stacks, unsigned slices) {
  unsigned nv = 2 + slices * (stacks - 1), nt = 2 * slices * (stacks - 1);
  float* v = malloc(sizeof(float) * 3 * nv);
  unsigned* t = malloc(sizeof(unsigned) * 3 * nt);
  sphere_mesh(stacks, slices, v, t);
  FILE* f = fopen(path, "w");
  if (!f) { perror(path); return 1; }
  fprintf(f, "# UV sphere %u x %u, %u triangles\n", stacks, slices, nt);
  for (unsigned i = 0; i < nv; i++) fprintf(f, "v %.9g %.9g %.9g\n", v[3 * i], v[3 * i + 1], v[3 * i + 2]);
  for (unsigned i = 0; i < nt; i++) fprintf(f, "f %u %u %u\n", t[3 * i] + 1, t[3 * i + 1] + 1, t[3 * i + 2] + 1);
  fclose(f);
  free(v);
  free(t);
  printf("wrote %s: %u vertices, %u triangles\n", path, nv, nt);
  return 0;
}

int main(int argc, char** argv) {
  if (argc > 2 && strcmp(argv[1], "--obj") == 0) {
    unsigned stacks = argc > 3 ? atoi(argv[3]) : 160, slices = argc > 4 ? atoi(argv[4]) : 318;
    if (stacks < 2 || slices < 3) { fprintf(stderr, "stacks >= 2, slices >= 3\n"); return 2; }
    return write_obj(argv[2], stacks, slices);
  }
  unsigned stacks = argc > 1 ? atoi(argv[1]) : 160, slices = argc > 2 ? atoi(argv[2]) : 318;
  unsigned size = argc > 3 ? atoi(argv[3]) : 1024;
  int runs = argc > 4 ? atoi(argv[4]) : 5, passes = argc > 5 ? atoi(argv[5]) : 3;
  if (stacks < 2 || slices < 3 || size < 1 || runs < 1 || runs > 99 || passes < 1) {
    fprintf(stderr, "usage: %s [stacks>=2 slices>=3 size runs passes]\n", argv[0]);
    return 2;
  }
  _MM_SET_FLUSH_ZERO_MODE(_MM_FLUSH_ZERO_ON);
  _MM_SET_DENORMALS_ZERO_MODE(_MM_DENORMALS_ZERO_ON);

  RTCDevice device = rtcNewDevice(NULL);
  if (!device) { fprintf(stderr, "rtcNewDevice failed: %d\n", (int)rtcGetDeviceError(NULL)); return 1; }
  rtcSetDeviceErrorFunction(device, error_handler, NULL);
  RTCScene scene = uv_sphere(device, stacks, slices);

  unsigned w = size, h = size;
  size_t n = (size_t)w * h;
  Ray* rays = malloc(n * sizeof(Ray));
  camera_rays(rays, w, h);

  unsigned long hs = single_pass(scene, rays, n), hp = packet_pass(scene, rays, w, h); /* warm-up */
  double rs[99], rp[99];
  for (int i = 0; i < runs; i++) {
    double t0 = now();
    for (int k = 0; k < passes; k++) hs = single_pass(scene, rays, n);
    double t1 = now();
    for (int k = 0; k < passes; k++) hp = packet_pass(scene, rays, w, h);
    double t2 = now();
    rs[i] = (double)n * passes / (t1 - t0) / 1e6;
    rp[i] = (double)n * passes / (t2 - t1) / 1e6;
  }
  qsort(rs, runs, sizeof(double), cmp_double);
  qsort(rp, runs, sizeof(double), cmp_double);
  printf("embree C baseline: UV sphere %u x %u = %u triangles, %ux%u camera rays, 1 thread, median of %d runs x %d passes\n",
         stacks, slices, 2 * slices * (stacks - 1), w, h, runs, passes);
  printf("hits: single %lu, packet %lu (of %zu rays)\n", hs, hp, n);
  printf("rtcIntersect1           %8.2f Mrays/s\n", rs[runs / 2]);
  printf("rtcIntersect4 coherent  %8.2f Mrays/s  (%.2fx)\n", rp[runs / 2], rp[runs / 2] / rs[runs / 2]);

  free(rays);
  rtcReleaseScene(scene);
  rtcReleaseDevice(device);
  return 0;
}
