#include "viewer/osmesa_renderer.hpp"

// OSMesa's header pulls in GL/gl.h; both are C headers of the Mesa packages.
#include <GL/gl.h>
#include <GL/osmesa.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <opencv2/imgproc.hpp>
#include <string>
#include <vector>

#if defined(__SANITIZE_ADDRESS__)
// LeakSanitizer (the ASan build): Mesa's OSMesa library, which carries gallium and llvmpipe, keeps
// its per-context framebuffer records and LLVM's JIT state until the process exits, and LSan
// reports them as leaks at exit. This hook of the sanitizer runtime suppresses reports whose
// allocation stack runs through those two libraries only; every leak of ours (any stack without
// them) is still reported. It is compiled into whatever links the renderer (sirupp-viewer, the
// viewer tests, the benchmark), so child processes of the CLI tests need no environment.
extern "C" const char* __lsan_default_suppressions();
extern "C" const char* __lsan_default_suppressions() { return "leak:libOSMesa.so\nleak:libLLVM\n"; }
#endif

namespace sirupp::viewer {

namespace {

// How far the real arm and the ghost are pushed back in depth (glPolygonOffset units), so that
// where they coincide with the virtual arm the virtual one shows. A rotated copy of a tessellated
// cylinder (the turret at another waist angle) differs from the original by the facets' sagitta,
// about 0.4 mm on the PUMA: the offset covers that at viewing distances of a metre or two.
constexpr float kBehindFactor = 1.0F;
constexpr float kBehindUnits = 200.0F;

constexpr int kCylinderSlices = 28;
constexpr int kSphereSlices = 24;
constexpr int kSphereStacks = 14;

void Vertex(const Eigen::Vector3d& normal, const Eigen::Vector3d& point) {
  glNormal3d(normal.x(), normal.y(), normal.z());
  glVertex3d(point.x(), point.y(), point.z());
}

// Unit box: edges 1, centred on the origin; counter-clockwise seen from outside.
void EmitBox() {
  glBegin(GL_TRIANGLES);
  for (int axis = 0; axis < 3; ++axis) {
    for (int sign = -1; sign <= 1; sign += 2) {
      Eigen::Vector3d normal = Eigen::Vector3d::Zero();
      normal[axis] = sign;
      const Eigen::Vector3d u = Eigen::Vector3d::Unit((axis + 1) % 3) * 0.5;
      const Eigen::Vector3d v = Eigen::Vector3d::Unit((axis + 2) % 3) * 0.5 * sign;
      const Eigen::Vector3d centre = normal * 0.5;
      const Eigen::Vector3d corners[4] = {centre - u - v, centre + u - v, centre + u + v,
                                          centre - u + v};
      for (int i : {0, 1, 2, 0, 2, 3}) Vertex(normal, corners[i]);
    }
  }
  glEnd();
}

// Unit cylinder: radius 1, axis z from -0.5 to 0.5, with both caps.
void EmitCylinder() {
  glBegin(GL_TRIANGLES);
  for (int i = 0; i < kCylinderSlices; ++i) {
    const double a0 = 2 * M_PI * i / kCylinderSlices;
    const double a1 = 2 * M_PI * (i + 1) / kCylinderSlices;
    const Eigen::Vector3d n0(std::cos(a0), std::sin(a0), 0);
    const Eigen::Vector3d n1(std::cos(a1), std::sin(a1), 0);
    const Eigen::Vector3d half(0, 0, 0.5);
    // Side.
    Vertex(n0, n0 - half);
    Vertex(n1, n1 - half);
    Vertex(n1, n1 + half);
    Vertex(n0, n0 - half);
    Vertex(n1, n1 + half);
    Vertex(n0, n0 + half);
    // Caps.
    const Eigen::Vector3d up = Eigen::Vector3d::UnitZ();
    Vertex(up, half);
    Vertex(up, n0 + half);
    Vertex(up, n1 + half);
    Vertex(-up, -half);
    Vertex(-up, n1 - half);
    Vertex(-up, n0 - half);
  }
  glEnd();
}

// Unit sphere: radius 1.
void EmitSphere() {
  auto point = [](int stack, int slice) {
    const double polar = M_PI * stack / kSphereStacks;
    const double around = 2 * M_PI * slice / kSphereSlices;
    return Eigen::Vector3d(std::sin(polar) * std::cos(around), std::sin(polar) * std::sin(around),
                           std::cos(polar));
  };
  glBegin(GL_TRIANGLES);
  for (int stack = 0; stack < kSphereStacks; ++stack) {
    for (int slice = 0; slice < kSphereSlices; ++slice) {
      const Eigen::Vector3d p00 = point(stack, slice), p01 = point(stack, slice + 1);
      const Eigen::Vector3d p10 = point(stack + 1, slice), p11 = point(stack + 1, slice + 1);
      if (stack > 0) {
        Vertex(p00, p00);
        Vertex(p10, p10);
        Vertex(p01, p01);
      }
      if (stack < kSphereStacks - 1) {
        Vertex(p01, p01);
        Vertex(p10, p10);
        Vertex(p11, p11);
      }
    }
  }
  glEnd();
}

void SetColour(const Rgba& rgba) { glColor4f(rgba[0], rgba[1], rgba[2], rgba[3]); }

}  // namespace

struct OsmesaRenderer::Impl {
  OSMesaContext context = nullptr;
  int render_width = 0;
  int render_height = 0;
  std::vector<uint8_t> buffer;  // BGRA, rows top to bottom
  GLuint lists = 0;             // box, cylinder, sphere
  cv::Mat reduced;              // BGRA at the output size
  cv::Mat frame;                // BGR at the output size, what Render returns

  void MakeCurrent() {
    if (OSMesaGetCurrentContext() == context) return;
    if (!OSMesaMakeCurrent(context, buffer.data(), GL_UNSIGNED_BYTE, render_width, render_height)) {
      throw RenderError("OSMesaMakeCurrent failed for a " + std::to_string(render_width) + "x" +
                        std::to_string(render_height) + " buffer");
    }
  }

  void DrawShape(const SceneShape& shape) const {
    glPushMatrix();
    glMultMatrixd(shape.pose.matrix().data());  // Eigen stores column-major, as OpenGL wants
    const Eigen::Vector3d& size = shape.size_m;
    switch (shape.type) {
      case core::ShapeType::kBox:
        glScaled(size.x(), size.y(), size.z());
        glCallList(lists);
        break;
      case core::ShapeType::kCylinder:
        glScaled(size.x(), size.x(), size.y());
        glCallList(lists + 1);
        break;
      case core::ShapeType::kSphere:
        glScaled(size.x(), size.x(), size.x());
        glCallList(lists + 2);
        break;
      case core::ShapeType::kCapsule:
        glPushMatrix();
        glScaled(size.x(), size.x(), size.y());
        glCallList(lists + 1);
        glPopMatrix();
        for (int end = -1; end <= 1; end += 2) {
          glPushMatrix();
          glTranslated(0, 0, end * size.y() / 2);
          glScaled(size.x(), size.x(), size.x());
          glCallList(lists + 2);
          glPopMatrix();
        }
        break;
    }
    glPopMatrix();
  }
};

OsmesaRenderer::OsmesaRenderer(const RenderOptions& options)
    : options_(options), impl_(std::make_unique<Impl>()) {
  if (options_.width < 16 || options_.width > kMaxSize || options_.height < 16 ||
      options_.height > kMaxSize) {
    throw RenderError("image size " + std::to_string(options_.width) + "x" +
                      std::to_string(options_.height) + " is outside 16..4096 pixels per side");
  }
  if (options_.supersample < 1 || options_.supersample > 4) {
    throw RenderError("supersample " + std::to_string(options_.supersample) + " is outside 1..4");
  }
  impl_->render_width = options_.width * options_.supersample;
  impl_->render_height = options_.height * options_.supersample;
  if (impl_->render_width > 8192 || impl_->render_height > 8192) {
    throw RenderError("image size times supersample is beyond 8192 pixels per side");
  }
  impl_->buffer.assign(static_cast<size_t>(impl_->render_width) * impl_->render_height * 4, 0);
  impl_->context = OSMesaCreateContextExt(OSMESA_BGRA, 24, 0, 0, nullptr);
  if (impl_->context == nullptr) {
    throw RenderError("OSMesaCreateContextExt failed (is libOSMesa from libosmesa6 installed?)");
  }
  try {
    impl_->MakeCurrent();
  } catch (...) {
    OSMesaDestroyContext(impl_->context);
    throw;
  }
  OSMesaPixelStore(OSMESA_Y_UP, 0);  // row 0 of the buffer is the top of the image

  const char* version = reinterpret_cast<const char*>(glGetString(GL_VERSION));
  const char* renderer = reinterpret_cast<const char*>(glGetString(GL_RENDERER));
  gl_description_ = std::string(version != nullptr ? version : "?") + " " +
                    (renderer != nullptr ? renderer : "?");

  impl_->lists = glGenLists(3);
  glNewList(impl_->lists, GL_COMPILE);
  EmitBox();
  glEndList();
  glNewList(impl_->lists + 1, GL_COMPILE);
  EmitCylinder();
  glEndList();
  glNewList(impl_->lists + 2, GL_COMPILE);
  EmitSphere();
  glEndList();

  glViewport(0, 0, impl_->render_width, impl_->render_height);
  glEnable(GL_DEPTH_TEST);
  glDepthFunc(GL_LEQUAL);
  glEnable(GL_CULL_FACE);
  glCullFace(GL_BACK);
  glEnable(GL_NORMALIZE);  // shapes are scaled non-uniformly
  glShadeModel(GL_SMOOTH);
  glEnable(GL_COLOR_MATERIAL);
  glColorMaterial(GL_FRONT_AND_BACK, GL_AMBIENT_AND_DIFFUSE);
  const GLfloat specular[] = {0.25F, 0.25F, 0.25F, 1.0F};
  glMaterialfv(GL_FRONT_AND_BACK, GL_SPECULAR, specular);
  glMaterialf(GL_FRONT_AND_BACK, GL_SHININESS, 28.0F);
  const GLfloat ambient[] = {0.30F, 0.30F, 0.32F, 1.0F};
  glLightModelfv(GL_LIGHT_MODEL_AMBIENT, ambient);
  const GLfloat key_diffuse[] = {0.72F, 0.72F, 0.70F, 1.0F};
  const GLfloat fill_diffuse[] = {0.28F, 0.28F, 0.32F, 1.0F};
  const GLfloat none[] = {0, 0, 0, 1};
  glLightfv(GL_LIGHT0, GL_DIFFUSE, key_diffuse);
  glLightfv(GL_LIGHT0, GL_SPECULAR, specular);
  glLightfv(GL_LIGHT1, GL_DIFFUSE, fill_diffuse);
  glLightfv(GL_LIGHT1, GL_SPECULAR, none);
  glEnable(GL_LIGHT0);
  glEnable(GL_LIGHT1);
  glBlendFunc(GL_SRC_ALPHA, GL_ONE_MINUS_SRC_ALPHA);
  glHint(GL_PERSPECTIVE_CORRECTION_HINT, GL_FASTEST);
}

OsmesaRenderer::~OsmesaRenderer() {
  if (impl_->context != nullptr) OSMesaDestroyContext(impl_->context);
}

const cv::Mat& OsmesaRenderer::Render(const Scene& scene, const Camera& camera) {
  Impl& impl = *impl_;
  impl.MakeCurrent();
  const int ss = options_.supersample;
  const Rgba& bg = options_.background;
  glClearColor(bg[0], bg[1], bg[2], 1.0F);
  glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);

  glMatrixMode(GL_PROJECTION);
  const Eigen::Matrix4d projection =
      ProjectionMatrix(camera, static_cast<double>(options_.width) / options_.height);
  glLoadMatrixd(projection.data());
  glMatrixMode(GL_MODELVIEW);
  // Lights in eye coordinates: a key light from above right of the camera, a fill from the left.
  glLoadIdentity();
  const GLfloat key_direction[] = {0.45F, 0.65F, 0.85F, 0.0F};
  const GLfloat fill_direction[] = {-0.7F, -0.1F, 0.5F, 0.0F};
  glLightfv(GL_LIGHT0, GL_POSITION, key_direction);
  glLightfv(GL_LIGHT1, GL_POSITION, fill_direction);
  const Eigen::Matrix4d view = ViewMatrix(camera);
  glLoadMatrixd(view.data());

  // Opaque solids: the virtual arm, the environment, the floor (pushed back so that the grid
  // lines on it show).
  glEnable(GL_LIGHTING);
  glDisable(GL_BLEND);
  glDepthMask(GL_TRUE);
  std::vector<const SceneShape*> translucent;
  for (const SceneShape& shape : scene.shapes) {
    if (shape.role == Role::kRealArm) continue;
    if (shape.rgba[3] < 1.0F) {
      translucent.push_back(&shape);
      continue;
    }
    const bool floor = shape.role == Role::kFloor;
    if (floor) {
      glEnable(GL_POLYGON_OFFSET_FILL);
      glPolygonOffset(2.0F, 2.0F * kBehindUnits);
    }
    SetColour(shape.rgba);
    impl.DrawShape(shape);
    if (floor) glDisable(GL_POLYGON_OFFSET_FILL);
  }
  // The real arm, pushed slightly back: where it coincides with the virtual arm, the virtual one
  // shows, so only the difference between the two appears in the real arm's colour.
  glEnable(GL_POLYGON_OFFSET_FILL);
  glPolygonOffset(kBehindFactor, kBehindUnits);
  for (const SceneShape& shape : scene.shapes) {
    if (shape.role != Role::kRealArm) continue;
    if (shape.rgba[3] < 1.0F) {
      translucent.push_back(&shape);
      continue;
    }
    SetColour(shape.rgba);
    impl.DrawShape(shape);
  }
  glDisable(GL_POLYGON_OFFSET_FILL);

  // Floor lines, depth-tested.
  glDisable(GL_LIGHTING);
  glLineWidth(static_cast<GLfloat>(ss));
  glBegin(GL_LINES);
  for (const SceneLine& line : scene.lines) {
    if (line.role == Role::kFrameAxis) continue;
    SetColour(line.rgba);
    glVertex3d(line.from_m.x(), line.from_m.y(), line.from_m.z());
    glVertex3d(line.to_m.x(), line.to_m.y(), line.to_m.z());
  }
  glEnd();

  // Translucent solids (the ghost): a depth-only pass first, so that only their nearest surfaces
  // are blended and a ghost does not show its own inner faces.
  // Pushed back like the real arm, so that a ghost coinciding with the virtual arm (at rest) leaves
  // it in its own colours.
  if (!translucent.empty()) {
    glEnable(GL_LIGHTING);
    glEnable(GL_POLYGON_OFFSET_FILL);
    glPolygonOffset(kBehindFactor, kBehindUnits);
    glColorMask(GL_FALSE, GL_FALSE, GL_FALSE, GL_FALSE);
    for (const SceneShape* shape : translucent) impl.DrawShape(*shape);
    glColorMask(GL_TRUE, GL_TRUE, GL_TRUE, GL_TRUE);
    glDepthMask(GL_FALSE);
    glEnable(GL_BLEND);
    for (const SceneShape* shape : translucent) {
      SetColour(shape->rgba);
      impl.DrawShape(*shape);
    }
    glDisable(GL_BLEND);
    glDisable(GL_POLYGON_OFFSET_FILL);
    glDepthMask(GL_TRUE);
    glDisable(GL_LIGHTING);
  }

  // DH frame axes on top of everything: they sit inside the links they belong to.
  glDisable(GL_DEPTH_TEST);
  glLineWidth(static_cast<GLfloat>(2.5 * ss));
  glBegin(GL_LINES);
  for (const SceneLine& line : scene.lines) {
    if (line.role != Role::kFrameAxis) continue;
    SetColour(line.rgba);
    glVertex3d(line.from_m.x(), line.from_m.y(), line.from_m.z());
    glVertex3d(line.to_m.x(), line.to_m.y(), line.to_m.z());
  }
  glEnd();
  glEnable(GL_DEPTH_TEST);
  glFinish();

  const cv::Mat drawn(impl.render_height, impl.render_width, CV_8UC4, impl.buffer.data());
  if (ss > 1) {
    cv::resize(drawn, impl.reduced, cv::Size(options_.width, options_.height), 0, 0,
               cv::INTER_AREA);
    cv::cvtColor(impl.reduced, impl.frame, cv::COLOR_BGRA2BGR);
  } else {
    cv::cvtColor(drawn, impl.frame, cv::COLOR_BGRA2BGR);
  }
  if (options_.overlay) DrawOverlay(impl.frame, scene.overlay);
  return impl.frame;
}

void DrawOverlay(cv::Mat& image, const std::vector<std::string>& lines) {
  const double scale = 0.42 * image.rows / 480.0;
  const int thickness = std::max(1, static_cast<int>(std::lround(image.rows / 480.0)));
  const int line_height = static_cast<int>(std::lround(18.0 * image.rows / 480.0));
  int y = line_height;
  for (const std::string& line : lines) {
    const cv::Point origin(static_cast<int>(std::lround(8.0 * image.rows / 480.0)), y);
    cv::putText(image, line, origin, cv::FONT_HERSHEY_SIMPLEX, scale, cv::Scalar(255, 255, 255),
                thickness + 2, cv::LINE_AA);
    cv::putText(image, line, origin, cv::FONT_HERSHEY_SIMPLEX, scale, cv::Scalar(30, 30, 30),
                thickness, cv::LINE_AA);
    y += line_height;
  }
}

}  // namespace sirupp::viewer
