// Sign-in by the university's front (class/front_auth.hpp): which requests' user header is
// believed, the client address for the throttle and the log, and the class file's front keys.
// The same rules through a real Apache: tests/package/front_test.py.

#include <gtest/gtest.h>
#include <sys/stat.h>

#include <filesystem>
#include <fstream>
#include <map>

#include "class/class_config.hpp"
#include "class/front_auth.hpp"
#include "core/errors.hpp"
#include "core/printable.hpp"
#include "tests/class_server_harness.hpp"

namespace sirupp::classroom {
namespace {

const char* const kSecret = "0123456789abcdef0123456789abcdef";

FrontConfig Front() {
  FrontConfig c;
  c.address = "127.0.0.1";
  c.secret = kSecret;
  c.secret_file = "/etc/sirupp/front.secret";
  c.teachers = {"jsmith"};
  return c;
}

// Judge() with these headers.
FrontVerdict JudgeWith(const FrontAuth& auth, const std::string& peer,
                       const std::map<std::string, std::string>& headers) {
  return auth.Judge(peer, [&headers](const std::string& name) {
    const auto it = headers.find(name);
    return it == headers.end() ? std::string() : it->second;
  });
}

using Kind = FrontVerdict::Kind;

TEST(FrontAuthTest, WithoutAFrontEveryRequestIsJudgedByItsToken) {
  const FrontAuth none;
  EXPECT_FALSE(none.enabled());
  const FrontVerdict v =
      JudgeWith(none, "127.0.0.1", {{"X-Remote-User", "alice"}, {kFrontSecretHeader, kSecret}});
  EXPECT_EQ(v.kind, Kind::kNoFront) << "no front: the headers mean nothing, tokens decide";
  EXPECT_EQ(none.ClientAddress(
                "10.0.0.5",
                [](const std::string& name) { return name == "X-Forwarded-For" ? "1.2.3.4" : ""; }),
            "10.0.0.5")
      << "without a front, a client's X-Forwarded-For is not believed";
}

TEST(FrontAuthTest, TheUserHeaderCountsOnlyFromTheFrontWithItsSecret) {
  const FrontAuth auth(Front());
  const FrontVerdict good =
      JudgeWith(auth, "127.0.0.1", {{"X-Remote-User", "alice"}, {kFrontSecretHeader, kSecret}});
  EXPECT_EQ(good.kind, Kind::kUser);
  EXPECT_EQ(good.user, "alice");
  EXPECT_EQ(
      JudgeWith(auth, "::ffff:127.0.0.1", {{"X-Remote-User", "bob"}, {kFrontSecretHeader, kSecret}})
          .kind,
      Kind::kUser)
      << "an IPv4-mapped peer is the same address";

  const FrontVerdict no_secret = JudgeWith(auth, "127.0.0.1", {{"X-Remote-User", "alice"}});
  EXPECT_EQ(no_secret.kind, Kind::kRefused);
  EXPECT_NE(no_secret.reason.find("without the front's secret"), std::string::npos)
      << no_secret.reason;

  const FrontVerdict wrong = JudgeWith(
      auth, "127.0.0.1", {{"X-Remote-User", "alice"}, {kFrontSecretHeader, "0123456789abcdeX"}});
  EXPECT_EQ(wrong.kind, Kind::kRefused);
  EXPECT_NE(wrong.reason.find("does not match /etc/sirupp/front.secret"), std::string::npos)
      << wrong.reason;
  EXPECT_EQ(wrong.reason.find(kSecret), std::string::npos) << "the secret is never echoed";

  const FrontVerdict elsewhere =
      JudgeWith(auth, "10.1.2.3", {{"X-Remote-User", "alice"}, {kFrontSecretHeader, kSecret}});
  EXPECT_EQ(elsewhere.kind, Kind::kRefused) << "the right secret from another address";
  EXPECT_NE(elsewhere.reason.find("from 10.1.2.3, which is not this class's front"),
            std::string::npos)
      << elsewhere.reason;
  EXPECT_EQ(JudgeWith(auth, "10.1.2.3", {{kFrontSecretHeader, "guess"}}).kind, Kind::kRefused);

  const FrontVerdict nobody = JudgeWith(auth, "127.0.0.1", {{kFrontSecretHeader, kSecret}});
  EXPECT_EQ(nobody.kind, Kind::kRefused);
  EXPECT_NE(nobody.reason.find("no user"), std::string::npos) << nobody.reason;

  EXPECT_EQ(JudgeWith(auth, "127.0.0.1", {}).kind, Kind::kNoFront)
      << "no front header: the token decides (the teacher on the server itself)";
  EXPECT_EQ(JudgeWith(auth, "10.1.2.3", {}).kind, Kind::kNoFront);
}

TEST(FrontAuthTest, ACustomUserHeader) {
  FrontConfig c = Front();
  c.user_header = "X-Shib-User";
  const FrontAuth auth(c);
  EXPECT_EQ(
      JudgeWith(auth, "127.0.0.1", {{"X-Shib-User", "bob"}, {kFrontSecretHeader, kSecret}}).user,
      "bob");
  EXPECT_EQ(
      JudgeWith(auth, "127.0.0.1", {{"X-Remote-User", "bob"}, {kFrontSecretHeader, kSecret}}).kind,
      Kind::kRefused)
      << "the secret alone, without the configured user header";
}

// ClientAddress() with these headers.
std::string ClientWith(const FrontAuth& auth, const std::string& peer,
                       const std::map<std::string, std::string>& headers) {
  return auth.ClientAddress(peer, [&headers](const std::string& name) {
    const auto it = headers.find(name);
    return it == headers.end() ? std::string() : it->second;
  });
}

TEST(FrontAuthTest, ClientAddressFromXForwardedForOnlyFromTheFront) {
  const FrontAuth auth(Front());
  const auto vouched = [](const std::string& forwarded_for) {
    return std::map<std::string, std::string>{{kFrontSecretHeader, kSecret},
                                              {"X-Forwarded-For", forwarded_for}};
  };
  EXPECT_EQ(ClientWith(auth, "127.0.0.1", vouched("192.0.2.7")), "192.0.2.7");
  EXPECT_EQ(ClientWith(auth, "127.0.0.1", vouched("6.6.6.6, 192.0.2.7")), "192.0.2.7")
      << "the last entry is the one the front added; earlier ones came from the client";
  EXPECT_EQ(ClientWith(auth, "127.0.0.1", vouched("2001:db8::1")), "2001:db8::1");
  EXPECT_EQ(ClientWith(auth, "127.0.0.1", vouched("")), "127.0.0.1");
  EXPECT_EQ(ClientWith(auth, "127.0.0.1", vouched("not-an-address")), "127.0.0.1");
  EXPECT_EQ(ClientWith(auth, "10.1.2.3", vouched("192.0.2.7")), "10.1.2.3")
      << "a client's own X-Forwarded-For would let it dodge the bad-token throttle";
}

TEST(FrontAuthTest, XForwardedForFromTheFrontsAddressWithoutTheSecretIsNotBelieved) {
  // Any program on the machine can connect from the front's address (127.0.0.1).
  const FrontAuth auth(Front());
  EXPECT_EQ(ClientWith(auth, "127.0.0.1", {{"X-Forwarded-For", "198.51.100.1"}}), "127.0.0.1");
  EXPECT_EQ(ClientWith(auth, "127.0.0.1",
                       {{"X-Forwarded-For", "198.51.100.1"}, {kFrontSecretHeader, "guess"}}),
            "127.0.0.1");
  EXPECT_EQ(ClientWith(auth, "127.0.0.1",
                       {{"X-Forwarded-For", "198.51.100.1"},
                        {kFrontSecretHeader, std::string(kSecret) + " "}}),
            "127.0.0.1")
      << "the secret byte for byte";
  EXPECT_FALSE(auth.Vouched("127.0.0.1", [](const std::string&) { return std::string(); }));
  EXPECT_EQ(ClientWith(FrontAuth(), "127.0.0.1",
                       {{"X-Forwarded-For", "198.51.100.1"}, {kFrontSecretHeader, kSecret}}),
            "127.0.0.1")
      << "no front: nothing of it is believed";
}

TEST(FrontAuthTest, ASignedInNameIsTakenAsSentAndMustBeOfTheClasssSyntax) {
  const FrontAuth auth(Front());
  for (const std::string& bad :
       std::vector<std::string>{"%61lice", "al%69ce", "alice@example.edu", "alice bob", "",
                                std::string(33, 'a'), ".alice", "al\tice"}) {
    const FrontVerdict v =
        JudgeWith(auth, "127.0.0.1", {{"X-Remote-User", bad}, {kFrontSecretHeader, kSecret}});
    if (bad.empty()) {
      EXPECT_EQ(v.kind, Kind::kRefused);  // no user
      continue;
    }
    EXPECT_EQ(v.kind, Kind::kRefused) << bad;
    EXPECT_NE(v.reason.find("'" + core::Printable(bad, 60) + "'"), std::string::npos)
        << "the refusal names the value as sent: " << v.reason;
    EXPECT_NE(v.reason.find("allowed: 1 to 32 letters"), std::string::npos) << v.reason;
  }
  EXPECT_EQ(
      JudgeWith(auth, "127.0.0.1", {{"X-Remote-User", "a.b-c_9"}, {kFrontSecretHeader, kSecret}})
          .user,
      "a.b-c_9");
}

TEST(FrontAuthTest, RolesOfSignedInNames) {
  const FrontAuth auth(Front());
  const std::vector<std::string> students = {"alice", "bob"};
  EXPECT_EQ(auth.RoleOf("alice", students), "student");
  EXPECT_EQ(auth.RoleOf("jsmith", students), "teacher");
  EXPECT_EQ(auth.RoleOf("mallory", students), "");
  EXPECT_EQ(auth.RoleOf("teacher", students), "") << "the token's reserved name is no sign-in";
  EXPECT_TRUE(SameAddress("::1", "0:0:0:0:0:0:0:1"));
  EXPECT_FALSE(SameAddress("127.0.0.1", "127.0.0.2"));
  EXPECT_FALSE(SameAddress("localhost", "localhost")) << "names are not addresses";
}

class FrontConfigTest : public ::testing::Test {
 protected:
  void SetUp() override { dir_ = testing::TempDir("sirupp-front-config"); }
  void TearDown() override { std::filesystem::remove_all(dir_); }

  void WriteSecret(const std::string& text, mode_t mode) {
    const std::string file = dir_ + "/front.secret";
    std::ofstream(file) << text;
    ::chmod(file.c_str(), mode);
  }
  ClassConfig Parse(const std::string& server) {
    return ParseClassConfig(
        "class: a\nrobot: config/robots/puma260.yaml\nstudents: [alice, bob]\ndata: d\n"
        "server: " +
            server + "\n",
        "c.yaml", dir_);
  }
  std::string ErrorOf(const std::string& server) {
    try {
      Parse(server);
    } catch (const core::ConfigError& e) {
      return e.what();
    }
    return "";
  }
  std::string dir_;
};

TEST_F(FrontConfigTest, ReadsTheFrontKeys) {
  WriteSecret(std::string(kSecret) + "\n", 0640);
  EXPECT_FALSE(Parse("{port: 0}").front.has_value()) << "no trusted_proxy: tokens only";
  const ClassConfig c = Parse(
      "{trusted_proxy: 127.0.0.1, proxy_secret_file: front.secret, "
      "proxy_user_header: X-Shib-User, proxy_teachers: [jsmith]}");
  ASSERT_TRUE(c.front.has_value());
  EXPECT_EQ(c.front->address, "127.0.0.1");
  EXPECT_EQ(c.front->secret, kSecret) << "the line's end is not part of the secret";
  EXPECT_EQ(c.front->secret_file, dir_ + "/front.secret");
  EXPECT_EQ(c.front->user_header, "X-Shib-User");
  EXPECT_EQ(c.front->teachers, std::vector<std::string>{"jsmith"});
  EXPECT_EQ(Parse("{trusted_proxy: '::1', proxy_secret_file: front.secret}").front->user_header,
            kDefaultUserHeader);
}

TEST_F(FrontConfigTest, BadFrontKeysNameTheirPlaceAndWhatIsAllowed) {
  WriteSecret(kSecret, 0640);
  std::string e =
      ErrorOf("{trusted_proxy: lab-front.example.edu, proxy_secret_file: front.secret}");
  EXPECT_NE(e.find("c.yaml:5"), std::string::npos) << e;
  EXPECT_NE(e.find("'lab-front.example.edu' is not an IP address"), std::string::npos) << e;
  e = ErrorOf("{trusted_proxy: 127.0.0.1}");
  EXPECT_NE(e.find("proxy_secret_file"), std::string::npos) << e;
  e = ErrorOf("{proxy_user_header: X-Remote-User}");
  EXPECT_NE(e.find("proxy_user_header without trusted_proxy"), std::string::npos) << e;
  e = ErrorOf("{trusted_proxy: 127.0.0.1, proxy_secret_file: none.secret}");
  EXPECT_NE(e.find("'none.secret': no such file"), std::string::npos) << e;
  e = ErrorOf(
      "{trusted_proxy: 127.0.0.1, proxy_secret_file: front.secret, proxy_user_header: 'X User'}");
  EXPECT_NE(e.find("'X User' is not a header for the user"), std::string::npos) << e;
  e = ErrorOf(
      "{trusted_proxy: 127.0.0.1, proxy_secret_file: front.secret, proxy_teachers: [teacher]}");
  EXPECT_NE(e.find("'teacher' is not a sign-in name"), std::string::npos) << e;

  WriteSecret(kSecret, 0644);
  e = ErrorOf("{trusted_proxy: 127.0.0.1, proxy_secret_file: front.secret}");
  EXPECT_NE(e.find("readable by every account on this machine (mode 0644)"), std::string::npos)
      << e;
  WriteSecret("short\n", 0600);
  e = ErrorOf("{trusted_proxy: 127.0.0.1, proxy_secret_file: front.secret}");
  EXPECT_NE(e.find("holds no usable secret"), std::string::npos) << e;
}

}  // namespace
}  // namespace sirupp::classroom
