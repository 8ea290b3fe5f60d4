// The JobStore contract: what BakeScheduler relies on, run unchanged
// against every engine (SQLite, and PostgreSQL on a real server this test
// starts itself). An engine that passes can carry the one scheduler logic.
#include <set>

#include <gtest/gtest.h>

#include "absl/strings/str_cat.h"

#include "tests/server/job_store_test_engines.h"

namespace impostor::testing {
namespace {

template <class Engine>
class JobStoreContract : public ::testing::Test {
 protected:
  void SetUp() override {
    auto store = Engine::Make();
    ASSERT_TRUE(store.ok()) << store.status();
    store_ = std::move(*store);
  }

  // A leader job; `key` is its cache key.
  JobRecord Job(const std::string& id, const std::string& key, v1::JobState state = v1::JOB_STATE_QUEUED,
                int64_t created_ms = 0, const std::string& client = "c") {
    JobRecord r;
    r.job.set_job_id(id);
    r.job.set_cache_key(key);
    r.job.set_state(state);
    r.job.set_created_ms(created_ms == 0 ? ++clock_ : created_ms);
    r.job.set_stage(state == v1::JOB_STATE_QUEUED ? "queued" : "");
    r.mesh.mutable_entry()->set_path("model.glb");
    r.mesh.mutable_entry()->mutable_digest()->set_hash("in-" + id);
    r.parameters.set_frames(8);
    r.client_id = client;
    return r;
  }
  v1::Manifest Result(const std::string& key) {
    v1::Manifest m;
    m.set_cache_key(key);
    m.mutable_manifest_json()->set_hash("json-" + key);
    m.add_maps()->mutable_digest()->set_hash("map-" + key);
    return m;
  }
  JobRecord MustGet(const std::string& id) {
    auto r = store_->Get(id);
    EXPECT_TRUE(r.ok()) << r.status();
    EXPECT_TRUE(r.ok() && r->has_value()) << id;
    return r.ok() && r->has_value() ? **r : JobRecord();
  }

  std::unique_ptr<JobStore> store_;
  int64_t clock_ = 1000;
};

TYPED_TEST_SUITE(JobStoreContract, JobStoreEngines, EngineNames);

TYPED_TEST(JobStoreContract, InsertedJobReadsBackFieldForField) {
  JobRecord r = this->Job("job-1", "k1");
  r.job.set_priority(7);
  r.lease_priority = 9;
  r.request_id = "req-1";
  r.owner = "alice";
  r.gate.set_min_iou(0.5f);
  r.required_tags = {"gpu", "team-forest"};
  r.job.set_progress(0.25f);
  ASSERT_TRUE(this->store_->Insert(r).ok());
  const JobRecord got = this->MustGet("job-1");
  EXPECT_EQ(got.job.cache_key(), "k1");
  EXPECT_EQ(got.job.state(), v1::JOB_STATE_QUEUED);
  EXPECT_EQ(got.job.priority(), 7);
  EXPECT_EQ(got.job.progress(), 0.25f);
  EXPECT_EQ(got.lease_priority, 9);
  EXPECT_EQ(got.request_id, "req-1");
  EXPECT_EQ(got.owner, "alice");
  EXPECT_EQ(got.client_id, "c");
  EXPECT_FLOAT_EQ(got.gate.min_iou(), 0.5f);
  EXPECT_EQ(got.required_tags, (std::vector<std::string>{"gpu", "team-forest"}));
  EXPECT_EQ(got.mesh.entry().digest().hash(), "in-job-1");
  EXPECT_EQ(got.parameters.frames(), 8u);
  EXPECT_EQ(got.row_version, 0);
  auto missing = this->store_->Get("job-none");
  ASSERT_TRUE(missing.ok());
  EXPECT_FALSE(missing->has_value());
}

TYPED_TEST(JobStoreContract, UpdateIsCompareAndSwapOnRowVersion) {
  ASSERT_TRUE(this->store_->Insert(this->Job("job-1", "k1")).ok());
  JobRecord a = this->MustGet("job-1");
  JobRecord stale = a;
  a.job.set_stage("first");
  ASSERT_TRUE(this->store_->Update(a).ok());
  EXPECT_EQ(this->MustGet("job-1").row_version, 1);
  // A server acting on the old read changes nothing.
  stale.job.set_stage("stale");
  EXPECT_EQ(this->store_->Update(stale).code(), absl::StatusCode::kAborted);
  EXPECT_EQ(this->MustGet("job-1").job.stage(), "first");
  JobRecord ghost = this->Job("job-ghost", "k9");
  EXPECT_EQ(this->store_->Update(ghost).code(), absl::StatusCode::kNotFound);
}

TYPED_TEST(JobStoreContract, OneActiveLeaderPerCacheKey) {
  ASSERT_TRUE(this->store_->Insert(this->Job("job-1", "k1")).ok());
  // A second leader for the key (another server's identical request).
  EXPECT_EQ(this->store_->Insert(this->Job("job-2", "k1")).code(), absl::StatusCode::kAlreadyExists);
  // A follower of it is fine, and so is a finished job with the key.
  JobRecord follower = this->Job("job-3", "k1");
  follower.leader_job_id = "job-1";
  EXPECT_TRUE(this->store_->Insert(follower).ok());
  EXPECT_TRUE(this->store_->Insert(this->Job("job-4", "k1", v1::JOB_STATE_SUCCEEDED)).ok());
  auto followers = this->store_->ActiveFollowers("job-1");
  ASSERT_TRUE(followers.ok());
  ASSERT_EQ(followers->size(), 1u);
  EXPECT_EQ((*followers)[0].job.job_id(), "job-3");
  // Once the bake ends, the key may bake again.
  JobRecord done = this->MustGet("job-1");
  done.job.set_state(v1::JOB_STATE_FAILED);
  ASSERT_TRUE(this->store_->Update(done).ok());
  EXPECT_TRUE(this->store_->Insert(this->Job("job-5", "k1")).ok());
  auto active = this->store_->ActiveWithKey("k1");
  ASSERT_TRUE(active.ok() && active->has_value());
  EXPECT_EQ((*active)->job.job_id(), "job-5");
  // The same job id twice.
  EXPECT_EQ(this->store_->Insert(this->Job("job-5", "k7")).code(), absl::StatusCode::kAlreadyExists);
}

TYPED_TEST(JobStoreContract, RequestIdIsUniquePerClient) {
  JobRecord a = this->Job("job-1", "k1");
  a.request_id = "r1";
  ASSERT_TRUE(this->store_->Insert(a).ok());
  JobRecord b = this->Job("job-2", "k2");
  b.request_id = "r1";
  EXPECT_EQ(this->store_->Insert(b).code(), absl::StatusCode::kAlreadyExists);
  b.client_id = "other";
  EXPECT_TRUE(this->store_->Insert(b).ok());
  auto found = this->store_->FindByRequestId("c", "r1");
  ASSERT_TRUE(found.ok() && found->has_value());
  EXPECT_EQ((*found)->job.job_id(), "job-1");
  auto none = this->store_->FindByRequestId("c", "r2");
  ASSERT_TRUE(none.ok());
  EXPECT_FALSE(none->has_value());
}

// What the lease sweep settles: followers still waiting on a leader that
// finished (its server died between saving it and settling them).
TYPED_TEST(JobStoreContract, FinishedLeadersWithWaitingFollowersAreFound) {
  auto follower = [&](const std::string& id, const std::string& key, const std::string& leader, v1::JobState state) {
    JobRecord f = this->Job(id, key, state);
    f.leader_job_id = leader;
    return f;
  };
  ASSERT_TRUE(this->store_->Insert(this->Job("done", "k1", v1::JOB_STATE_SUCCEEDED)).ok());
  ASSERT_TRUE(this->store_->Insert(follower("f-waiting", "k1", "done", v1::JOB_STATE_QUEUED)).ok());
  ASSERT_TRUE(this->store_->Insert(this->Job("failed", "k2", v1::JOB_STATE_FAILED)).ok());
  ASSERT_TRUE(this->store_->Insert(follower("f-settled", "k2", "failed", v1::JOB_STATE_FAILED)).ok());
  ASSERT_TRUE(this->store_->Insert(this->Job("live", "k3", v1::JOB_STATE_RUNNING)).ok());
  ASSERT_TRUE(this->store_->Insert(follower("f-live", "k3", "live", v1::JOB_STATE_QUEUED)).ok());
  ASSERT_TRUE(this->store_->Insert(this->Job("alone", "k4", v1::JOB_STATE_CANCELLED)).ok());
  auto found = this->store_->FinishedLeadersWithWaitingFollowers(10);
  ASSERT_TRUE(found.ok()) << found.status();
  ASSERT_EQ(found->size(), 1u);
  EXPECT_EQ(found->front().job.job_id(), "done");
  auto none = this->store_->FinishedLeadersWithWaitingFollowers(0);
  ASSERT_TRUE(none.ok()) << none.status();
  EXPECT_TRUE(none->empty());
}

// The lookup every cache hit with a request_id makes (SQLite keeps its
// statement prepared between calls): each call sees its own arguments and
// the rows written since.
TYPED_TEST(JobStoreContract, RepeatedRequestIdLookupsSeeEveryWrite) {
  for (int i = 0; i < 5; ++i) {
    const std::string id = absl::StrCat("r", i);
    auto before = this->store_->FindByRequestId("c", id);
    ASSERT_TRUE(before.ok()) << before.status();
    EXPECT_FALSE(before->has_value()) << id;
    JobRecord job = this->Job(absl::StrCat("job-", i), absl::StrCat("k", i));
    job.request_id = id;
    ASSERT_TRUE(this->store_->Insert(job).ok());
    for (int j = 0; j <= i; ++j) {
      auto found = this->store_->FindByRequestId("c", absl::StrCat("r", j));
      ASSERT_TRUE(found.ok() && found->has_value()) << "r" << j;
      EXPECT_EQ((*found)->job.job_id(), absl::StrCat("job-", j));
    }
    auto other_client = this->store_->FindByRequestId("other", id);
    ASSERT_TRUE(other_client.ok());
    EXPECT_FALSE(other_client->has_value());
  }
}

TYPED_TEST(JobStoreContract, ClaimLeasesTheFirstCandidateStillQueued) {
  ASSERT_TRUE(this->store_->Insert(this->Job("job-a", "ka")).ok());
  ASSERT_TRUE(this->store_->Insert(this->Job("job-b", "kb")).ok());
  JobRecord follower = this->Job("job-f", "ka");
  follower.leader_job_id = "job-a";
  ASSERT_TRUE(this->store_->Insert(follower).ok());
  const LeaseGrant grant{.lease_id = "lease-1", .lease_deadline_ms = 5000, .worker_id = "w1",
                         .lease_holder = "tok", .now_ms = 4000};
  auto first = this->store_->ClaimQueued({"job-f", "job-b", "job-a"}, grant);
  ASSERT_TRUE(first.ok()) << first.status();
  ASSERT_TRUE(first->has_value());
  EXPECT_EQ((*first)->job.job_id(), "job-b");  // followers are never leased
  const JobRecord b = this->MustGet("job-b");
  EXPECT_EQ(b.job.state(), v1::JOB_STATE_RUNNING);
  EXPECT_EQ(b.job.attempts(), 1u);
  EXPECT_EQ(b.job.stage(), "leased");
  EXPECT_EQ(b.job.worker_id(), "w1");
  EXPECT_EQ(b.job.updated_ms(), 4000);
  EXPECT_EQ(b.lease_id, "lease-1");
  EXPECT_EQ(b.lease_deadline_ms, 5000);
  EXPECT_EQ(b.worker_id, "w1");
  EXPECT_EQ(b.lease_holder, "tok");
  EXPECT_EQ(b.row_version, (*first)->row_version);
  // Taken: a second claim of it finds nothing, the next candidate instead.
  auto again = this->store_->ClaimQueued({"job-b"}, grant);
  ASSERT_TRUE(again.ok());
  EXPECT_FALSE(again->has_value());
  auto next = this->store_->ClaimQueued({"job-b", "job-a"}, {.lease_id = "lease-2", .worker_id = "w2"});
  ASSERT_TRUE(next.ok() && next->has_value());
  EXPECT_EQ((*next)->job.job_id(), "job-a");
  auto empty = this->store_->ClaimQueued({}, grant);
  ASSERT_TRUE(empty.ok());
  EXPECT_FALSE(empty->has_value());
  // The claimed record can be saved on (its row_version is current).
  JobRecord a = **next;
  a.job.set_progress(0.5f);
  EXPECT_TRUE(this->store_->Update(a).ok());
}

TYPED_TEST(JobStoreContract, QueueHeadsAreTheOldestPerClientAtTheTopPriority) {
  JobRecord low = this->Job("job-low", "k0", v1::JOB_STATE_QUEUED, 1, "x");
  ASSERT_TRUE(this->store_->Insert(low).ok());
  for (auto [id, client, t] : {std::tuple{"job-x2", "x", 3}, {"job-x1", "x", 2}, {"job-y1", "y", 4}}) {
    JobRecord r = this->Job(id, std::string("k-") + id, v1::JOB_STATE_QUEUED, t, client);
    r.lease_priority = 5;
    ASSERT_TRUE(this->store_->Insert(r).ok());
  }
  auto heads = this->store_->QueueHeadsPerClient({});
  ASSERT_TRUE(heads.ok()) << heads.status();
  std::set<std::string> ids;
  for (const auto& r : *heads) ids.insert(r.job.job_id());
  EXPECT_EQ(ids, (std::set<std::string>{"job-x1", "job-y1"}));
  auto oldest = this->store_->OldestQueued();
  ASSERT_TRUE(oldest.ok() && oldest->has_value());
  EXPECT_EQ((*oldest)->job.job_id(), "job-low");
}

// What the scheduler asks when a worker should skip jobs it failed itself
// (SchedulerOptions::retry_elsewhere_ms): the heads of the rest of the queue.
TYPED_TEST(JobStoreContract, QueueHeadsLeaveOutTheSkippedJobs) {
  for (auto [id, client, t, priority] : {std::tuple{"job-x1", "x", 2, 5}, {"job-x2", "x", 3, 5}, {"job-y1", "y", 4, 5},
                                         {"job-z1", "z", 5, 1}}) {
    JobRecord r = this->Job(id, std::string("k-") + id, v1::JOB_STATE_QUEUED, t, client);
    r.lease_priority = priority;
    ASSERT_TRUE(this->store_->Insert(r).ok());
  }
  struct Case {
    const char* name;
    std::vector<std::string> skip;
    std::set<std::string> heads;
  };
  const Case cases[] = {
      {"nothing skipped", {}, {"job-x1", "job-y1"}},
      {"a client's head skipped: its next job", {"job-x1"}, {"job-x2", "job-y1"}},
      {"every job at the top priority skipped: the next priority", {"job-x1", "job-x2", "job-y1"}, {"job-z1"}},
      {"unknown ids are no error", {"job-none", "job-x1"}, {"job-x2", "job-y1"}},
      {"everything skipped", {"job-x1", "job-x2", "job-y1", "job-z1"}, {}},
  };
  for (const Case& c : cases) {
    auto heads = this->store_->QueueHeadsPerClient(c.skip);
    ASSERT_TRUE(heads.ok()) << c.name << ": " << heads.status();
    std::set<std::string> ids;
    for (const auto& r : *heads) ids.insert(r.job.job_id());
    EXPECT_EQ(ids, c.heads) << c.name;
  }
}

TYPED_TEST(JobStoreContract, RunningJobsAreFoundByWorkerHolderAndDeadline) {
  for (const char* id : {"job-1", "job-2", "job-3"}) ASSERT_TRUE(this->store_->Insert(this->Job(id, id)).ok());
  ASSERT_TRUE(this->store_->ClaimQueued({"job-1"}, {.lease_id = "l1", .lease_deadline_ms = 100, .worker_id = "w1",
                                                    .lease_holder = "h1"}).ok());
  ASSERT_TRUE(this->store_->ClaimQueued({"job-2"}, {.lease_id = "l2", .lease_deadline_ms = 300, .worker_id = "w2",
                                                    .lease_holder = "h2"}).ok());
  auto on_w1 = this->store_->RunningOnWorker("w1");
  ASSERT_TRUE(on_w1.ok());
  ASSERT_EQ(on_w1->size(), 1u);
  EXPECT_EQ((*on_w1)[0].job.job_id(), "job-1");
  auto by_h2 = this->store_->RunningLeasedBy("h2");
  ASSERT_TRUE(by_h2.ok());
  ASSERT_EQ(by_h2->size(), 1u);
  EXPECT_EQ((*by_h2)[0].job.job_id(), "job-2");
  auto expired = this->store_->ExpiredLeases(200);
  ASSERT_TRUE(expired.ok());
  ASSERT_EQ(expired->size(), 1u);
  EXPECT_EQ((*expired)[0].job.job_id(), "job-1");
  auto running = this->store_->RunningPerClient();
  ASSERT_TRUE(running.ok());
  EXPECT_EQ(running->at("c"), 2);
  auto pending = this->store_->Pending();
  ASSERT_TRUE(pending.ok());
  EXPECT_EQ(pending->size(), 3u);
  EXPECT_EQ(*this->store_->CountPending(""), 3);
  EXPECT_EQ(*this->store_->CountPending("c"), 3);
  EXPECT_EQ(*this->store_->CountPending("nobody"), 0);
  JobRecord mine = this->Job("job-4", "k4");
  mine.owner = "bob";
  ASSERT_TRUE(this->store_->Insert(mine).ok());
  EXPECT_EQ(*this->store_->CountPendingOwnedBy("bob"), 1);
  auto counts = this->store_->CountByState();
  ASSERT_TRUE(counts.ok());
  EXPECT_EQ(counts->at(v1::JOB_STATE_RUNNING), 2);
  EXPECT_EQ(counts->at(v1::JOB_STATE_QUEUED), 2);
}

// A leader whose requester cancelled but that baked on for its followers is
// SUCCEEDED in its row and CANCELLED to its requester (GetJob): the listings
// count and filter it as the requester sees it.
TYPED_TEST(JobStoreContract, ListingsGoByTheStateTheRequesterSees) {
  JobRecord kept = this->Job("job-kept", "k1");
  kept.job.set_state(v1::JOB_STATE_SUCCEEDED);
  kept.requester_cancelled = true;
  ASSERT_TRUE(this->store_->Insert(kept).ok());
  JobRecord done = this->Job("job-done", "k2");
  done.job.set_state(v1::JOB_STATE_SUCCEEDED);
  ASSERT_TRUE(this->store_->Insert(done).ok());
  auto counts = this->store_->CountByState();
  ASSERT_TRUE(counts.ok()) << counts.status();
  EXPECT_EQ(counts->at(v1::JOB_STATE_CANCELLED), 1);
  EXPECT_EQ(counts->at(v1::JOB_STATE_SUCCEEDED), 1);
  auto cancelled = this->store_->ListJobs(v1::JOB_STATE_CANCELLED, 10, std::nullopt);
  ASSERT_TRUE(cancelled.ok());
  ASSERT_EQ(cancelled->size(), 1u);
  EXPECT_EQ((*cancelled)[0].job.job_id(), "job-kept");
  auto succeeded = this->store_->ListJobs(v1::JOB_STATE_SUCCEEDED, 10, std::nullopt);
  ASSERT_TRUE(succeeded.ok());
  ASSERT_EQ(succeeded->size(), 1u);
  EXPECT_EQ((*succeeded)[0].job.job_id(), "job-done");
}

TYPED_TEST(JobStoreContract, ResultsStoreTouchPinListAndDelete) {
  ASSERT_TRUE(this->store_->PutResult(this->Result("ka"), 10).ok());
  ASSERT_TRUE(this->store_->PutResult(this->Result("kb"), 20).ok());
  ASSERT_TRUE(this->store_->PutResult(this->Result("kc"), 30).ok());
  ASSERT_TRUE(this->store_->TouchResult("ka", 40).ok());
  auto lru = this->store_->ResultsByLastUse();
  ASSERT_TRUE(lru.ok());
  ASSERT_EQ(lru->size(), 3u);
  EXPECT_EQ((*lru)[0].manifest.cache_key(), "kb");
  EXPECT_EQ((*lru)[2].manifest.cache_key(), "ka");
  EXPECT_TRUE(*this->store_->PinResult("kb", true));
  EXPECT_FALSE(*this->store_->PinResult("k-none", true));
  auto stored = this->store_->GetStoredResult("kb");
  ASSERT_TRUE(stored.ok() && stored->has_value());
  EXPECT_TRUE((*stored)->pinned);
  EXPECT_EQ((*stored)->created_ms, 20);
  EXPECT_TRUE(*this->store_->IsResultBlob("map-kb"));
  EXPECT_TRUE(*this->store_->IsResultBlob("json-kc"));
  EXPECT_FALSE(*this->store_->IsResultBlob("in-job-1"));
  // Newest first, two per page.
  auto page1 = this->store_->ListResults(2, std::nullopt);
  ASSERT_TRUE(page1.ok());
  ASSERT_EQ(page1->size(), 2u);
  EXPECT_EQ((*page1)[0].manifest.cache_key(), "kc");
  auto page2 = this->store_->ListResults(
      2, JobStore::ResultCursor{(*page1)[1].created_ms, (*page1)[1].manifest.cache_key()});
  ASSERT_TRUE(page2.ok());
  ASSERT_EQ(page2->size(), 1u);
  EXPECT_EQ((*page2)[0].manifest.cache_key(), "ka");
  ASSERT_TRUE(this->store_->DeleteResult("kb").ok());
  auto gone = this->store_->GetResult("kb");
  ASSERT_TRUE(gone.ok());
  EXPECT_FALSE(gone->has_value());
  EXPECT_FALSE(*this->store_->IsResultBlob("map-kb"));
  auto kept = this->store_->GetResult("ka");
  ASSERT_TRUE(kept.ok() && kept->has_value());
  EXPECT_EQ((*kept)->maps(0).digest().hash(), "map-ka");
}

TYPED_TEST(JobStoreContract, JobListingPagesNewestFirst) {
  for (int i = 1; i <= 5; ++i) {
    ASSERT_TRUE(this->store_->Insert(this->Job("job-" + std::to_string(i), "k" + std::to_string(i),
                                               i == 3 ? v1::JOB_STATE_SUCCEEDED : v1::JOB_STATE_QUEUED, 100 * i))
                    .ok());
  }
  auto page = this->store_->ListJobs(0, 2, std::nullopt);
  ASSERT_TRUE(page.ok()) << page.status();
  ASSERT_EQ(page->size(), 2u);
  EXPECT_EQ((*page)[0].job.job_id(), "job-5");
  EXPECT_EQ((*page)[1].job.job_id(), "job-4");
  auto next = this->store_->ListJobs(0, 10, JobStore::JobCursor{400, "job-4"});
  ASSERT_TRUE(next.ok());
  ASSERT_EQ(next->size(), 3u);
  EXPECT_EQ((*next)[0].job.job_id(), "job-3");
  auto done = this->store_->ListJobs(v1::JOB_STATE_SUCCEEDED, 10, std::nullopt);
  ASSERT_TRUE(done.ok());
  ASSERT_EQ(done->size(), 1u);
  EXPECT_EQ((*done)[0].job.job_id(), "job-3");
  auto filtered_after = this->store_->ListJobs(v1::JOB_STATE_QUEUED, 10, JobStore::JobCursor{300, "job-3"});
  ASSERT_TRUE(filtered_after.ok());
  EXPECT_EQ(filtered_after->size(), 2u);
  EXPECT_EQ(*this->store_->OldestJobWithKey("k2"), "job-2");
  EXPECT_EQ(*this->store_->OldestJobWithKey("k-none"), "");
}

TYPED_TEST(JobStoreContract, FairnessHistoryOrdersClientsByLastService) {
  auto none = this->store_->LastServed();
  ASSERT_TRUE(none.ok());
  EXPECT_TRUE(none->empty());
  ASSERT_TRUE(this->store_->NoteServed("a").ok());
  ASSERT_TRUE(this->store_->NoteServed("b").ok());
  ASSERT_TRUE(this->store_->NoteServed("a").ok());
  auto served = this->store_->LastServed();
  ASSERT_TRUE(served.ok());
  ASSERT_EQ(served->size(), 2u);
  EXPECT_GT(served->at("a"), served->at("b"));
}

TYPED_TEST(JobStoreContract, ALoneServerIsTheMaintainer) {
  auto held = this->store_->HoldMaintenanceLock();
  ASSERT_TRUE(held.ok()) << held.status();
  EXPECT_TRUE(*held);
  EXPECT_TRUE(*this->store_->HoldMaintenanceLock());  // and stays it
}

}  // namespace
}  // namespace impostor::testing
