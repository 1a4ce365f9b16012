#include "planning/collision_model.hpp"

#include <ode/ode.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <map>
#include <mutex>
#include <random>
#include <stdexcept>

#include "core/errors.hpp"
#include "planning/narrow_phase.hpp"

namespace sirupp::planning {
namespace {

using core::FormatNumber;

constexpr int kSelfSamples = 300;    // states sampled to find link pairs always in contact
constexpr double kMaxPadding = 0.1;  // m
constexpr int kMaxContactsPerPair = 8;

// What dGeomGetData points at: an arm shape (index into Impl::shapes) or an object.
struct GeomTag {
  bool arm = false;
  int index = 0;
};

void ToOde(const Eigen::Matrix3d& r, dMatrix3 out) {
  for (int row = 0; row < 3; ++row) {
    for (int col = 0; col < 3; ++col) out[row * 4 + col] = r(row, col);
    out[row * 4 + 3] = 0;
  }
}

void Place(dGeomID geom, const Eigen::Isometry3d& pose) {
  dMatrix3 rotation;
  ToOde(pose.linear(), rotation);
  dGeomSetPosition(geom, pose.translation().x(), pose.translation().y(), pose.translation().z());
  dGeomSetRotation(geom, rotation);
}

dGeomID CreateGeom(dSpaceID space, const core::Shape& shape, double margin) {
  const Eigen::Vector3d& s = shape.size_m;
  switch (shape.type) {
    case core::ShapeType::kBox:
      return dCreateBox(space, s.x() + 2 * margin, s.y() + 2 * margin, s.z() + 2 * margin);
    case core::ShapeType::kCylinder:
      return dCreateCylinder(space, s.x() + margin, s.y() + 2 * margin);
    case core::ShapeType::kCapsule:
      return dCreateCapsule(space, s.x() + margin, s.y());
    case core::ShapeType::kSphere:
      return dCreateSphere(space, s.x() + margin);
  }
  throw std::logic_error("unknown shape type");
}

std::string Point(const Eigen::Vector3d& p) {
  char text[96];
  std::snprintf(text, sizeof text, "(%.3f, %.3f, %.3f) m", p.x(), p.y(), p.z());
  return text;
}

}  // namespace

const char* ContactKindName(ContactKind kind) {
  switch (kind) {
    case ContactKind::kStaticObject:
      return "static object";
    case ContactKind::kFreeObject:
      return "free object";
    case ContactKind::kSelf:
      return "self";
  }
  return "?";
}

int CSpaceSlice::free_count() const {
  return static_cast<int>(std::count(cells.begin(), cells.end(), kCellFree));
}

struct CollisionModel::Impl {
  core::RobotModel model;
  core::Environment environment;
  CollisionOptions options;
  std::vector<core::DhLink> dh;
  Eigen::Isometry3d base = Eigen::Isometry3d::Identity();

  struct ArmShape {
    int link = 0, shape = 0;
    Eigen::Isometry3d local = Eigen::Isometry3d::Identity();
    dGeomID padded = nullptr;  // in arm_space, against objects
    Solid solid;               // unpadded, in the world at the placed state (self pairs)
    double bound = 0;          // radius of a sphere about the centre holding the shape
  };
  std::vector<ArmShape> shapes;
  std::vector<GeomTag> shape_tags;
  std::vector<dGeomID> object_geoms;
  std::vector<GeomTag> object_tags;
  dSpaceID arm_space = nullptr;
  dSpaceID static_space = nullptr;
  dSpaceID free_space = nullptr;
  int static_count = 0, free_count = 0;

  std::vector<std::pair<int, int>> self_pairs;  // link pairs
  std::vector<SkippedPair> skipped_pairs;
  std::vector<std::pair<int, int>> self_shape_pairs;  // shape index pairs of self_pairs
  uint64_t checked = 0;

  // Scratch.
  std::vector<Eigen::Isometry3d> frames;
  JointVector placed_q;

  Impl(const core::RobotModel& robot, const core::Environment& env, const CollisionOptions& opts)
      : model(robot), environment(env), options(opts) {
    if (model.num_joints() < 1 || model.links.size() != model.joints.size() + 1) {
      throw std::invalid_argument("collision model: model " + model.name +
                                  " needs one link per joint plus the base");
    }
    CheckPadding(options.padding_m);
    if (options.self_pair_samples < 0 || options.self_pair_samples > 1000000) {
      throw std::invalid_argument("self_pair_samples " + std::to_string(options.self_pair_samples) +
                                  ": allowed 0 to 1000000");
    }
    EnsureOdeReady();
    for (const core::Joint& joint : model.joints) dh.push_back(core::DhLink::From(joint));
    base = model.base.ToIsometry();
    frames.resize(model.links.size());
    arm_space = dSimpleSpaceCreate(nullptr);
    dSpaceSetCleanup(arm_space, 0);
    free_space = dSimpleSpaceCreate(nullptr);
    dSpaceSetCleanup(free_space, 0);
    BuildArm();
    BuildObjects();
    ChooseSelfPairs();
  }

  ~Impl() {
    for (ArmShape& s : shapes) {
      dGeomDestroy(s.padded);
    }
    for (dGeomID g : object_geoms) dGeomDestroy(g);
    dSpaceDestroy(arm_space);
    if (static_space != nullptr) dSpaceDestroy(static_space);
    dSpaceDestroy(free_space);
  }

  static void CheckPadding(double padding) {
    if (!(padding >= 0 && padding <= kMaxPadding)) {
      throw std::invalid_argument("padding " + FormatNumber(padding) + " m: allowed 0 to " +
                                  FormatNumber(kMaxPadding) + " m");
    }
  }

  void BuildArm() {
    for (size_t link = 0; link < model.links.size(); ++link) {
      const core::Link& l = model.links[link];
      for (size_t k = 0; k < l.shapes.size(); ++k) {
        ArmShape s;
        s.link = static_cast<int>(link);
        s.shape = static_cast<int>(k);
        s.local = l.shapes[k].pose.ToIsometry();
        s.solid = Solid::From(l.shapes[k], s.local);
        const Eigen::Vector3d& h = s.solid.half;
        switch (l.shapes[k].type) {
          case core::ShapeType::kBox:
            s.bound = h.norm();
            break;
          case core::ShapeType::kCylinder:
            s.bound = std::hypot(h.x(), h.z());
            break;
          case core::ShapeType::kCapsule:
            s.bound = h.x() + h.z();
            break;
          case core::ShapeType::kSphere:
            s.bound = h.x();
            break;
        }
        shapes.push_back(s);
      }
    }
    shape_tags.resize(shapes.size());
    for (size_t i = 0; i < shapes.size(); ++i) shape_tags[i] = GeomTag{true, static_cast<int>(i)};
    MakeArmGeoms();
  }

  void MakeArmGeoms() {
    for (size_t i = 0; i < shapes.size(); ++i) {
      ArmShape& s = shapes[i];
      const core::Shape& shape =
          model.links[static_cast<size_t>(s.link)].shapes[static_cast<size_t>(s.shape)];
      s.padded = CreateGeom(arm_space, shape, options.padding_m);
      dGeomSetData(s.padded, &shape_tags[i]);
    }
    placed_q.resize(0);
  }

  void BuildObjects() {
    std::vector<dGeomID> statics;
    object_tags.resize(environment.objects.size());
    for (size_t i = 0; i < environment.objects.size(); ++i) {
      const core::EnvironmentObject& object = environment.objects[i];
      object_tags[i] = GeomTag{false, static_cast<int>(i)};
      dGeomID geom = CreateGeom(object.is_static ? nullptr : free_space, object.shape, 0);
      dGeomSetData(geom, &object_tags[i]);
      Place(geom, object.shape.pose.ToIsometry());
      object_geoms.push_back(geom);
      if (object.is_static) {
        statics.push_back(geom);
      } else {
        ++free_count;
      }
    }
    static_count = static_cast<int>(statics.size());
    if (statics.size() <= 64) {
      static_space = dSimpleSpaceCreate(nullptr);
    } else {
      static_space = QuadTreeSpaceAround(statics);
    }
    dSpaceSetCleanup(static_space, 0);
    for (dGeomID g : statics) dSpaceAdd(static_space, g);
  }

  void CheckState(const JointVector& q) const {
    if (q.size() != model.num_joints()) {
      throw std::invalid_argument("joint state has " + std::to_string(q.size()) +
                                  " values; model " + model.name + " has " +
                                  std::to_string(model.num_joints()) + " joints");
    }
    for (int j = 0; j < q.size(); ++j) {
      if (!std::isfinite(q[j])) {
        throw std::invalid_argument("joint state: j" + std::to_string(j + 1) + " is " +
                                    FormatNumber(q[j]) + "; allowed a finite value");
      }
    }
  }

  void ComputeFrames(const JointVector& q) {
    Eigen::Matrix3d r = base.linear();
    Eigen::Vector3d p = base.translation();
    frames[0] = base;
    for (size_t i = 0; i < dh.size(); ++i) {
      core::ApplyDh(model.dh_convention, dh[i], q[static_cast<Eigen::Index>(i)], r, p);
      Eigen::Isometry3d frame = Eigen::Isometry3d::Identity();
      frame.linear() = r;
      frame.translation() = p;
      frames[i + 1] = frame;
    }
  }

  void SetState(const JointVector& q) {
    ++checked;
    if (placed_q.size() == q.size() && placed_q == q) return;
    ComputeFrames(q);
    const bool first = placed_q.size() == 0;
    for (ArmShape& s : shapes) {
      if (s.link == 0 && !first) continue;  // the base never moves
      const Eigen::Isometry3d pose = frames[static_cast<size_t>(s.link)] * s.local;
      Place(s.padded, pose);
      s.solid.rotation = pose.linear();
      s.solid.centre = pose.translation();
    }
    placed_q = q;
  }

  // ---- queries ------------------------------------------------------------------------------
  struct Query {
    Impl* self = nullptr;
    bool want_all = false;  // collect every pair (Contacts), else stop at the first
    bool want_depth = false;
    bool found = false;
    ContactKind kind = ContactKind::kStaticObject;
    std::vector<Contact> contacts;
  };

  static Contact MakeContact(dGeomID a, dGeomID b, bool depth, ContactKind kind) {
    Contact c;
    c.kind = kind;
    if (!depth) return c;
    dContactGeom geoms[kMaxContactsPerPair];
    const int count = CollideGeoms(a, b, kMaxContactsPerPair, geoms, sizeof(dContactGeom));
    for (int k = 0; k < count; ++k) {
      if (k == 0 || geoms[k].depth > c.depth_m) {
        c.depth_m = std::max(0.0, static_cast<double>(geoms[k].depth));
        c.point_m = {geoms[k].pos[0], geoms[k].pos[1], geoms[k].pos[2]};
      }
    }
    return c;
  }

  void Fill(Contact& c, const GeomTag& arm, const GeomTag* other_arm, int object) const {
    const ArmShape& s = shapes[static_cast<size_t>(arm.index)];
    c.link = s.link;
    c.shape = s.shape;
    if (other_arm != nullptr) {
      const ArmShape& o = shapes[static_cast<size_t>(other_arm->index)];
      c.other_link = o.link;
      c.other_shape = o.shape;
      if (c.other_link < c.link) {
        std::swap(c.link, c.other_link);
        std::swap(c.shape, c.other_shape);
      }
    }
    c.object = object;
  }

  static void ObjectCallback(void* data, dGeomID a, dGeomID b) {
    auto* query = static_cast<Query*>(data);
    if (query->found && !query->want_all) return;
    const auto* tag_a = static_cast<const GeomTag*>(dGeomGetData(a));
    const auto* tag_b = static_cast<const GeomTag*>(dGeomGetData(b));
    const GeomTag* arm = tag_a->arm ? tag_a : tag_b;
    const GeomTag* object = tag_a->arm ? tag_b : tag_a;
    dGeomID arm_geom = tag_a->arm ? a : b;
    dGeomID object_geom = tag_a->arm ? b : a;
    Impl* self = query->self;
    const bool is_static = self->environment.objects[static_cast<size_t>(object->index)].is_static;
    // The base and the static objects never move: their overlap says nothing about a motion.
    if (is_static && self->shapes[static_cast<size_t>(arm->index)].link == 0) return;
    if (!GeomsOverlap(arm_geom, object_geom)) return;
    Contact c = MakeContact(arm_geom, object_geom, query->want_depth, query->kind);
    self->Fill(c, *arm, nullptr, object->index);
    query->contacts.push_back(c);
    query->found = true;
  }

  void CollideObjects(dSpaceID space, ContactKind kind, Query& query) {
    query.kind = kind;
    dSpaceCollide2(reinterpret_cast<dGeomID>(arm_space), reinterpret_cast<dGeomID>(space), &query,
                   &ObjectCallback);
  }

  // Whether two of the arm's shapes overlap: a bounding-sphere test, then the exact convex test
  // (narrow_phase.hpp: GJK on the shapes themselves), for every primitive pair.
  bool ShapesOverlap(int i, int j) const {
    const ArmShape& a = shapes[static_cast<size_t>(i)];
    const ArmShape& b = shapes[static_cast<size_t>(j)];
    const double reach = a.bound + b.bound;
    if ((a.solid.centre - b.solid.centre).squaredNorm() > reach * reach) return false;
    return SolidsOverlap(a.solid, b.solid);
  }

  void CollideSelf(Query& query) {
    for (const auto& [i, j] : self_shape_pairs) {
      if (query.found && !query.want_all) return;
      if (!ShapesOverlap(i, j)) continue;
      Contact c;
      c.kind = ContactKind::kSelf;
      if (query.want_depth) {
        const Penetration pen = EstimatePenetration(shapes[static_cast<size_t>(i)].solid,
                                                    shapes[static_cast<size_t>(j)].solid);
        c.depth_m = pen.depth_m;
        c.point_m = pen.point;
      }
      Fill(c, shape_tags[static_cast<size_t>(i)], &shape_tags[static_cast<size_t>(j)], -1);
      query.contacts.push_back(c);
      query.found = true;
    }
  }

  void Run(const JointVector& q, const CheckFilter& filter, Query& query) {
    SetState(q);
    query.self = this;
    if (filter.static_objects && static_count > 0) {
      CollideObjects(static_space, ContactKind::kStaticObject, query);
    }
    if ((!query.found || query.want_all) && filter.free_objects && free_count > 0) {
      CollideObjects(free_space, ContactKind::kFreeObject, query);
    }
    if ((!query.found || query.want_all) && filter.self && options.self_collision) {
      CollideSelf(query);
    }
  }

  // ---- self pairs ---------------------------------------------------------------------------
  bool LinksOverlap(int first, int second) {
    for (size_t i = 0; i < shapes.size(); ++i) {
      if (shapes[i].link != first) continue;
      for (size_t j = 0; j < shapes.size(); ++j) {
        if (shapes[j].link != second) continue;
        if (ShapesOverlap(static_cast<int>(i), static_cast<int>(j))) return true;
      }
    }
    return false;
  }

  // What decides the self pairs: every link's shapes, every joint's DH row, limits and home, and
  // the sample count (so a cached choice is reused only for the same arm).
  std::string SelfPairKey() const {
    std::string key = std::to_string(options.self_pair_samples) + "|" +
                      std::to_string(static_cast<int>(model.dh_convention));
    char number[40];
    auto add = [&](double v) {
      std::snprintf(number, sizeof number, "%.17g,", v);
      key += number;
    };
    for (const core::Joint& j : model.joints) {
      for (double v : {j.dh.a_m, j.dh.alpha_rad, j.dh.d_m, j.dh.theta_rad, j.position_min,
                       j.position_max, j.home}) {
        add(v);
      }
      key += j.type == core::JointType::kRevolute ? "r|" : "p|";
    }
    for (const core::Link& l : model.links) {
      for (const core::Shape& shape : l.shapes) {
        key += std::to_string(static_cast<int>(shape.type)) + ":";
        for (int i = 0; i < 3; ++i) add(shape.size_m[i]);
        for (int i = 0; i < 3; ++i) add(shape.pose.position_m[i]);
        for (double v : shape.pose.orientation.coeffs()) add(v);
      }
      key += "|";
    }
    return key;
  }

  // The choice takes 10 000 states x the candidate pairs (about 50 ms for the PUMA 260): made once
  // per arm and process.
  void ChooseSelfPairs() {
    struct Choice {
      std::vector<std::pair<int, int>> pairs;
      std::vector<SkippedPair> skipped;
    };
    static std::mutex mutex;
    static std::map<std::string, Choice> cache;
    const std::string key = SelfPairKey();
    {
      std::lock_guard<std::mutex> lock(mutex);
      const auto it = cache.find(key);
      if (it != cache.end()) {
        self_pairs = it->second.pairs;
        skipped_pairs = it->second.skipped;
        ListSelfShapePairs();
        return;
      }
    }
    SampleSelfPairs();
    std::lock_guard<std::mutex> lock(mutex);
    if (cache.size() < 64) cache[key] = Choice{self_pairs, skipped_pairs};
  }

  void ListSelfShapePairs() {
    for (const auto& [first, second] : self_pairs) {
      for (size_t i = 0; i < shapes.size(); ++i) {
        if (shapes[i].link != first) continue;
        for (size_t j = 0; j < shapes.size(); ++j) {
          if (shapes[j].link == second) {
            self_shape_pairs.emplace_back(static_cast<int>(i), static_cast<int>(j));
          }
        }
      }
    }
  }

  void SampleSelfPairs() {
    const int links = static_cast<int>(model.links.size());
    std::vector<std::pair<int, int>> candidates;
    for (int i = 0; i < links; ++i) {
      for (int j = i + 2; j < links; ++j) {
        if (model.links[static_cast<size_t>(i)].shapes.empty() ||
            model.links[static_cast<size_t>(j)].shapes.empty()) {
          continue;
        }
        candidates.emplace_back(i, j);
      }
    }
    const int n = model.num_joints();
    JointVector home(n);
    for (int j = 0; j < n; ++j) home[j] = model.joints[static_cast<size_t>(j)].home;
    SetState(home);
    std::vector<std::pair<int, int>> remaining;
    for (const auto& pair : candidates) {
      if (LinksOverlap(pair.first, pair.second)) {
        skipped_pairs.push_back({pair.first, pair.second, "overlap at the home pose"});
      } else {
        remaining.push_back(pair);
      }
    }
    const int samples = options.self_pair_samples;
    std::vector<int> hits(remaining.size(), 0);
    std::mt19937 rng(20261202);
    JointVector q(n);
    for (int sample = 0; sample < samples; ++sample) {
      for (int j = 0; j < n; ++j) {
        const core::Joint& joint = model.joints[static_cast<size_t>(j)];
        q[j] = std::uniform_real_distribution<double>(joint.position_min, joint.position_max)(rng);
      }
      SetState(q);
      for (size_t k = 0; k < remaining.size(); ++k) {
        if (LinksOverlap(remaining[k].first, remaining[k].second)) ++hits[k];
      }
    }
    const std::string sampled = std::to_string(samples) + " random states within the limits";
    for (size_t k = 0; k < remaining.size(); ++k) {
      if (samples > 0 && hits[k] == samples) {
        skipped_pairs.push_back(
            {remaining[k].first, remaining[k].second, "overlap in every one of " + sampled});
      } else if (samples > 0 && hits[k] == 0) {
        skipped_pairs.push_back(
            {remaining[k].first, remaining[k].second, "touch in none of " + sampled});
      } else {
        self_pairs.push_back(remaining[k]);
      }
    }
    std::sort(self_pairs.begin(), self_pairs.end());
    ListSelfShapePairs();
    checked = 0;
  }
};

CollisionModel::CollisionModel(const core::RobotModel& model, const core::Environment& environment,
                               const CollisionOptions& options)
    : impl_(std::make_unique<Impl>(model, environment, options)) {}
CollisionModel::~CollisionModel() = default;
CollisionModel::CollisionModel(CollisionModel&&) noexcept = default;
CollisionModel& CollisionModel::operator=(CollisionModel&&) noexcept = default;

const core::RobotModel& CollisionModel::model() const { return impl_->model; }
const core::Environment& CollisionModel::environment() const { return impl_->environment; }
const CollisionOptions& CollisionModel::options() const { return impl_->options; }
int CollisionModel::num_joints() const { return impl_->model.num_joints(); }

void CollisionModel::SetObjectPose(const std::string& object_name, const Eigen::Isometry3d& pose) {
  const auto& objects = impl_->environment.objects;
  for (size_t i = 0; i < objects.size(); ++i) {
    if (objects[i].name != object_name) continue;
    if (objects[i].is_static) {
      throw std::invalid_argument("object '" + object_name + "' is static: only free objects move");
    }
    Place(impl_->object_geoms[i], pose);
    return;
  }
  throw std::invalid_argument("no object named '" + object_name + "' in environment " +
                              impl_->environment.name);
}

void CollisionModel::SetPadding(double padding_m) {
  Impl::CheckPadding(padding_m);
  if (padding_m == impl_->options.padding_m) return;
  for (Impl::ArmShape& s : impl_->shapes) {
    dGeomDestroy(s.padded);
  }
  impl_->options.padding_m = padding_m;
  impl_->MakeArmGeoms();
}

bool CollisionModel::IsFree(const JointVector& q, const CheckFilter& filter) {
  impl_->CheckState(q);
  Impl::Query query;
  impl_->Run(q, filter, query);
  return !query.found;
}

std::optional<Contact> CollisionModel::FirstContact(const JointVector& q,
                                                    const CheckFilter& filter) {
  impl_->CheckState(q);
  Impl::Query query;
  query.want_depth = true;
  impl_->Run(q, filter, query);
  if (query.contacts.empty()) return std::nullopt;
  return query.contacts.front();
}

std::optional<ContactKind> CollisionModel::FirstContactKind(const JointVector& q,
                                                            const CheckFilter& filter) {
  impl_->CheckState(q);
  Impl::Query query;
  impl_->Run(q, filter, query);
  if (query.contacts.empty()) return std::nullopt;
  return query.contacts.front().kind;
}

std::vector<Contact> CollisionModel::Contacts(const JointVector& q, const CheckFilter& filter) {
  impl_->CheckState(q);
  Impl::Query query;
  query.want_depth = true;
  query.want_all = true;
  impl_->Run(q, filter, query);
  return query.contacts;
}

namespace {
int EdgeSteps(const JointVector& from, const JointVector& to, double step_rad) {
  if (!(step_rad > 0) || !std::isfinite(step_rad)) {
    throw std::invalid_argument("edge step " + FormatNumber(step_rad) +
                                " rad: allowed a finite value > 0");
  }
  const double longest = (to - from).cwiseAbs().maxCoeff();
  const double steps = std::ceil(longest / step_rad);
  if (steps > 1e7) {
    throw std::invalid_argument("edge of " + FormatNumber(longest) + " rad at step " +
                                FormatNumber(step_rad) + " rad: more than 10^7 states");
  }
  return std::max(1, static_cast<int>(steps));
}
}  // namespace

EdgeCheck CollisionModel::CheckEdge(const JointVector& from, const JointVector& to, double step_rad,
                                    const CheckFilter& filter) {
  impl_->CheckState(from);
  impl_->CheckState(to);
  const int n = EdgeSteps(from, to, step_rad);
  EdgeCheck result;
  for (int k = 0; k <= n; ++k) {
    const double t = static_cast<double>(k) / n;
    const JointVector q = from + t * (to - from);
    ++result.states_checked;
    if (std::optional<Contact> contact = FirstContact(q, filter)) {
      result.free = false;
      result.fraction = t;
      result.state = q;
      result.contact = contact;
      return result;
    }
  }
  return result;
}

bool CollisionModel::EdgeFree(const JointVector& from, const JointVector& to, double step_rad,
                              const CheckFilter& filter) {
  impl_->CheckState(from);
  impl_->CheckState(to);
  const int n = EdgeSteps(from, to, step_rad);
  Impl::Query query;
  auto free_at = [&](int k) {
    const JointVector q = from + (static_cast<double>(k) / n) * (to - from);
    impl_->Run(q, filter, query);
    return !query.found;
  };
  if (!free_at(n)) return false;
  int stride = 1;
  while (stride * 2 < n) stride *= 2;
  for (; stride >= 1; stride /= 2) {
    for (int k = stride; k < n; k += 2 * stride) {
      if (!free_at(k)) return false;
    }
  }
  return true;
}

uint64_t CollisionModel::states_checked() const { return impl_->checked; }
void CollisionModel::ResetCounter() { impl_->checked = 0; }

const std::vector<std::pair<int, int>>& CollisionModel::SelfPairs() const {
  return impl_->self_pairs;
}
const std::vector<CollisionModel::SkippedPair>& CollisionModel::SkippedSelfPairs() const {
  return impl_->skipped_pairs;
}

std::string CollisionModel::LinkName(int link) const {
  const auto& links = impl_->model.links;
  if (link < 0 || link >= static_cast<int>(links.size())) return "link " + std::to_string(link);
  if (link == 0) return "the base (" + links[0].name + ")";
  return "link " + std::to_string(link) + " (" + links[static_cast<size_t>(link)].name + ")";
}

std::string CollisionModel::ObjectName(int object) const {
  const auto& objects = impl_->environment.objects;
  if (object < 0 || object >= static_cast<int>(objects.size())) {
    return "object #" + std::to_string(object);
  }
  const core::EnvironmentObject& o = objects[static_cast<size_t>(object)];
  return std::string(o.is_static ? "static" : "free") + " object '" + o.name + "'";
}

std::string CollisionModel::Describe(const Contact& contact) const {
  const std::string other = contact.kind == ContactKind::kSelf ? LinkName(contact.other_link)
                                                               : ObjectName(contact.object);
  char depth[32];
  std::snprintf(depth, sizeof depth, "%.1f", contact.depth_m * 1000);
  return LinkName(contact.link) + " touches " + other + " by " + depth + " mm at " +
         Point(contact.point_m);
}

std::vector<std::vector<Eigen::Isometry3d>> CollisionModel::ShapePoses(const JointVector& q) const {
  impl_->CheckState(q);
  const core::ForwardResult fk = core::ForwardKinematics(impl_->model, q);
  std::vector<std::vector<Eigen::Isometry3d>> out(impl_->model.links.size());
  for (size_t link = 0; link < impl_->model.links.size(); ++link) {
    for (const core::Shape& shape : impl_->model.links[link].shapes) {
      out[link].push_back(fk.frames[link] * shape.pose.ToIsometry());
    }
  }
  return out;
}

CSpaceSlice ComputeCSpaceSlice(CollisionModel& model, const JointVector& q, int joint_a,
                               int joint_b, double step_rad, const CheckFilter& filter) {
  const auto start = std::chrono::steady_clock::now();
  const int n = model.num_joints();
  auto check_joint = [&](int joint, const char* what) {
    if (joint < 0 || joint >= n) {
      throw std::invalid_argument(std::string(what) + " " + std::to_string(joint + 1) +
                                  ": allowed 1 to " + std::to_string(n));
    }
  };
  check_joint(joint_a, "joint_a");
  check_joint(joint_b, "joint_b");
  if (joint_a == joint_b) throw std::invalid_argument("joint_a and joint_b are the same joint");
  if (!(step_rad > 0 && step_rad <= 1)) {
    throw std::invalid_argument("C-space step " + FormatNumber(step_rad) +
                                " rad: allowed (0, 1] rad");
  }
  if (q.size() != n) {
    throw std::invalid_argument("C-space: q has " + std::to_string(q.size()) +
                                " values; model has " + std::to_string(n) + " joints");
  }
  auto grid = [&](int joint) {
    const core::Joint& j = model.model().joints[static_cast<size_t>(joint)];
    const int count =
        static_cast<int>(std::ceil((j.position_max - j.position_min) / step_rad - 1e-9)) + 1;
    std::vector<double> values(static_cast<size_t>(count));
    for (int i = 0; i < count; ++i) {
      values[static_cast<size_t>(i)] =
          j.position_min + (j.position_max - j.position_min) * i / std::max(1, count - 1);
    }
    return values;
  };
  CSpaceSlice slice;
  slice.joint_a = joint_a;
  slice.joint_b = joint_b;
  slice.values_a = grid(joint_a);
  slice.values_b = grid(joint_b);
  slice.cells.assign(slice.values_a.size() * slice.values_b.size(), kCellFree);
  JointVector state = q;
  for (size_t ib = 0; ib < slice.values_b.size(); ++ib) {
    state[joint_b] = slice.values_b[ib];
    for (size_t ia = 0; ia < slice.values_a.size(); ++ia) {
      state[joint_a] = slice.values_a[ia];
      // One query: the first contact is looked for among statics, then free objects, then the
      // arm itself, which is the cell's order of precedence.
      uint8_t cell = kCellFree;
      if (const std::optional<ContactKind> kind = model.FirstContactKind(state, filter)) {
        cell = *kind == ContactKind::kStaticObject ? kCellStatic
               : *kind == ContactKind::kFreeObject ? kCellFreeObject
                                                   : kCellSelf;
      }
      slice.cells[ib * slice.values_a.size() + ia] = cell;
    }
  }
  slice.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return slice;
}

}  // namespace sirupp::planning
